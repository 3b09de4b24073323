!> Truncated nonsmooth Newton multigrid (TNNMG; Graeser & Kornhuber 2009) for the
!> bound-constrained quadratic programme of the primal problems
!>
!>     minimise 1/2 x^T A x - F^T x   subject to   x_i free        (kind(i) = BOUND_FREE)
!>                                                 x_i >= bnd(i)   (kind(i) = BOUND_LOWER)
!>                                                 x_i  = bnd(i)   (kind(i) = BOUND_FIXED)
!>
!> on a hierarchy of uniformly refined meshes (`mg_hierarchy_t`: grid 1 the coarsest, grid
!> L = nlevel the finest, whose matrix is A).  Grid l is obtained from grid l-1 (nc nodes) by
!> red refinement with the numbering of dualsig_mesh_refine: nodes 1..nc are the coarse
!> nodes, node nc + e is the midpoint of coarse edge e = (ends(1,e), ends(2,e)), so the P1
!> prolongation copies the coarse values and averages the two ends at a midpoint.
!> A mesh without such a hierarchy (level 1 of a run, Gmsh meshes, adaptive steps) gets an
!> algebraic one (mg_build_algebraic): the prolongations are general sparse matrices from
!> smoothed aggregation of the matrix itself (dualsig_amg_aggregation), built on all nodes;
!> the truncation below is the same (frozen rows of P zeroed, Galerkin products recomputed
!> on the coarse rows that the changed unknowns reach).
!>
!> One iteration, from the iterate x:
!>  1. a symmetric projected Gauss-Seidel sweep (forward, backward; exact per node for
!>     bounds; `sweeps` half-sweeps);
!>  2. the residual r = F - A x and the KKT test (the stopping criterion of every qp solver,
!>     `kkt_residual`, computed from r without another product);
!>  3. truncation: the fixed unknowns and the bounded unknowns at their bound are frozen
!>     (weight 0, the truncated basis of TNNMG);
!>  4. a linear correction v on the free unknowns: one V(3,3) cycle (Gauss-Seidel,
!>     exact coarsest solve by CHOLMOD) on the Galerkin operators A_{L-1} = P_T^T A P_T
!>     (P_T: the prolongation with the rows of frozen unknowns zeroed) and
!>     A_{l-1} = P^T A_l P below; when the frozen set changes only the rows it reaches are
!>     recomputed (O(sqrt N) on a contact boundary);
!>  5. the projected direction w = max(x + v, bnd) - x on the bounded unknowns (v elsewhere)
!>     and the exact line search min_alpha J(x + alpha w) over the feasible alphas (w.Aw
!>     from grid L-1's operator and the rows of the clipped unknowns);
!>  6. a symmetric projected Gauss-Seidel sweep (backward, forward).
!> A zero start is first replaced by nested iteration on the coarser grids (fmg_start: the
!> QP restricted to each grid, one iteration per grid, interpolated upwards), so that cold
!> solves, too, take a number of iterations independent of h (on algebraic grids the
!> constraints of an aggregate restrict those of its members, restrict_bounds; the
!> iterations then grow slowly, 14-16 at 1.7e4 unknowns to 21-24 at 1e6: doc/performance.md).
!> Every step decreases the energy (monotone), so the iteration converges from any start;
!> once the contact set is found it is linear multigrid with h-independent rates (the KKT
!> residual falls by about 20 per iteration on the P1 and P2 scenes).
!> Work per iteration: four sweeps, one product with A and some vector work on the finest
!> grid, a third of that on the coarser ones; storage: the coarse
!> operators (about a third of A), the prolongations and two vectors and two masks on the
!> finest grid: about 80 bytes per unknown (mg_memory_bytes); a cold start holds, while it
!> runs, a copy of the untruncated coarse operators and loads (about 35 bytes more).
module dualsig_solver_multigrid
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, rect_t, csr_matvec, csr_gauss_seidel, csr_pattern_from_edges, rect_matvec, rect_matvec_t, &
                            csr_set_row_pattern, csr_move, rect_move
  use dualsig_amg_aggregation, only: amg_prolongation, amg_transpose, amg_galerkin_product, amg_galerkin_values, &
                                     amg_sweep_order, &
                                     amg_coarsest_max
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_refactor, cholesky_solve, &
                                  cholesky_free, ORDERING_AMD
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED, kkt_residual, kkt_scale, norm_acc_t, &
                              norm_acc_add, norm_acc_value
  use dualsig_status, only: status_t, set_error, set_warning, is_ok, DS_ERR_INPUT, DS_ERR_NUMERIC, &
                            DS_WARN_NOT_CONVERGED
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_LOGICAL, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: mg_hierarchy_t, mg_settings_t, mg_result_t
  public :: mg_reset, mg_add_level, mg_clear, multigrid_solve, mg_memory_bytes, mg_build_algebraic, mg_extend_algebraic, &
            mg_extend_algebraic_take, &
            mg_finest_size

  !> Most grids of an algebraic hierarchy (coarsening by ~9 per grid in 2D: never reached).
  integer, parameter :: amg_max_grids = 25
  !> An aggregation that keeps more than this fraction of the unknowns ends the coarsening.
  real(dp), parameter :: amg_min_coarsening = 0.8_dp
  !> Default limit of TNNMG iterations (each reduces the residual by about ten).
  integer, parameter :: mg_max_iter_default = 200
  !> The energy stop (mg_settings_t%energy_tol) predicts the decrease of J still to come
  !> from the last two decreases, as a geometric series with ratio q (J - J* = e^T A e / 2
  !> contracts by about q per iteration): remaining <= delta_k q / (1 - q).  Two ratios are
  !> compared and the larger taken; it is trusted only below energy_ratio_max (a slower
  !> iteration is not yet in its asymptotic regime) and taken at least energy_ratio_min (the
  !> first V-cycles remove the rough error much faster than the rest).
  real(dp), parameter :: energy_ratio_max = 0.8_dp, energy_ratio_min = 0.05_dp
  !> The coarsest grid is solved exactly by CHOLMOD (its factor is 1/4^(L-1) of the finest
  !> grid's size); symmetric Gauss-Seidel sweeps replace it when its truncated operator is
  !> only semi-definite and the factorisation fails.
  integer, parameter :: coarse_sweeps_fallback = 50
  !> The line search takes w.Aw from the coarse grid when the projection clips at most this
  !> fraction of the unknowns (a contact boundary: O(sqrt N)); else by a product with A.
  real(dp), parameter :: line_search_clip_max = 0.125_dp

  !> The prolongation from grid l-1 (nc nodes) to grid l (nf = nc + size(ends, 2) nodes) and
  !> its transpose by coarse node: the fine nodes child(cptr(I) : cptr(I+1)-1) contribute to
  !> coarse node I (I itself with weight 1, the midpoints of its edges with weight 1/2).
  type :: mg_transfer_t
    integer :: nc = 0, nf = 0
    integer, allocatable :: ends(:,:)     !! (2, nf - nc) coarse ends of the edge of midpoint nc + e
    integer, allocatable :: cptr(:)       !! (nc + 1)
    integer, allocatable :: child(:)      !! fine nodes by coarse node
    !> an algebraic grid (mg_build_algebraic): the prolongation is the general matrix p
    !> (nf x nc, smoothed aggregation) and pt = p^T; ends, cptr, child unused
    logical :: algebraic = .false.
    type(rect_t) :: p, pt
    integer, allocatable :: agg(:)        !! (nf) algebraic: the aggregate (coarse node) of each fine node
  end type mg_transfer_t

  !> A coarse grid's operator and vectors (built by the solve).
  type :: mg_grid_t
    type(csr_t) :: a
    real(dp), allocatable :: x(:), b(:), r(:)
  end type mg_grid_t

  !> The grid hierarchy: transfer(l) maps grid l-1 to grid l (l = 2..nlevel); grids
  !> 1..nlevel-1 hold the coarse operators of the last solve.
  type :: mg_hierarchy_t
    integer :: nlevel = 0                         !! grids; 0 = none
    integer :: n1 = 0                             !! nodes of grid 1
    type(mg_transfer_t), allocatable :: transfer(:)
    type(mg_grid_t), allocatable :: grid(:)
    type(cholesky_t) :: coarse                    !! factor of grid 1's operator
    logical :: coarse_ok = .false.                !! the factor is usable
    !> grids 1..nlevel-1 hold the untruncated P^T A P of the matrix setup_grids was given
    !> (set when setup_grids built every coarse operator by amg_galerkin_product; the next
    !> untruncated galerkin_algebraic of the same solve uses them instead of recomputing;
    !> cleared by it, at the end of every solve and by mg_clear, so a later solve with
    !> another matrix never takes them)
    logical :: values_fresh = .false.
  end type mg_hierarchy_t

  type :: mg_settings_t
    real(dp) :: tol = 1.0e-10_dp                  !! tolerance on the relative KKT residual
    integer :: max_iter = mg_max_iter_default     !! TNNMG iterations
    !> projected Gauss-Seidel sweeps before and after the correction, alternating forward and
    !> backward (2: a symmetric sweep each; half the iterations of 1 for the same sweeps)
    integer :: sweeps = 2
    !> Gauss-Seidel sweeps before and after, coarse grids (3: P1 needs 8 iterations at 10^6
    !> unknowns instead of 10 with 2, P2 7 with either)
    integer :: coarse_sweeps = 3
    !> a cold start (x = 0 on entry) replaced by nested iteration on the coarser grids
    !> (fmg_start), with this many iterations per coarser grid; 0: no such start
    integer :: fmg_cycles = 1
    !> with krylov and no bounds, > 0: also stop when the decrease of J(x) = x^T A x / 2 -
    !> f^T x still to come is predicted below this (J's units; predicted_gap): for a caller
    !> to whom J - J* is a known part of an error bound (the adaptive loop's dual)
    real(dp) :: energy_tol = 0.0_dp
    !> without bounds (every unknown BOUND_FREE): conjugate gradients preconditioned by one
    !> symmetric V-cycle instead of the plain V-cycles (pcg_linear); ignored with bounds
    logical :: krylov = .false.
  end type mg_settings_t

  type :: mg_result_t
    integer :: iterations = 0                     !! TNNMG iterations (V-cycles)
    integer :: galerkin_updates = 0               !! recomputations of the coarse operators (frozen set changed)
    integer :: grids = 0                          !! grids of the hierarchy used
    real(dp) :: kkt_residual = 0.0_dp             !! relative KKT residual of the returned x
    logical :: converged = .false.
    !> stopped by settings%energy_tol (converged is then .true. whatever kkt_residual)
    logical :: energy_stop = .false.
    !> with settings%energy_tol: the predicted decrease of J still to come at the return
    !> (J(x) - J(x*), a prediction; huge when none could be made)
    real(dp) :: energy_gap = 0.0_dp
  end type mg_result_t

contains

  !> Start a hierarchy whose coarsest grid has n1 nodes (nlevel = 1: no coarse grid yet).
  subroutine mg_reset(h, n1)
    type(mg_hierarchy_t), intent(inout) :: h
    integer, intent(in) :: n1
    call mg_clear(h)
    h%nlevel = 1
    h%n1 = n1
  end subroutine mg_reset

  !> Forget the hierarchy (nlevel = 0), e.g. after a refinement that is not uniform.
  subroutine mg_clear(h)
    type(mg_hierarchy_t), intent(inout) :: h
    call cholesky_free(h%coarse)
    h%coarse_ok = .false.
    h%values_fresh = .false.
    if (allocated(h%transfer)) deallocate (h%transfer)
    if (allocated(h%grid)) deallocate (h%grid)
    h%nlevel = 0
    h%n1 = 0
  end subroutine mg_clear

  !> Append a grid made by red refinement of the current finest one (nc nodes, its edges
  !> `edge_nodes(2, nedge)`; the new grid has nc + nedge nodes, numbered as in
  !> dualsig_mesh_refine).  st: DS_ERR_INPUT when nc is not the current finest size.
  subroutine mg_add_level(h, nc, edge_nodes, st)
    type(mg_hierarchy_t), intent(inout) :: h
    integer, intent(in) :: nc
    integer, intent(in) :: edge_nodes(:,:)
    type(status_t), intent(out) :: st
    type(mg_transfer_t), allocatable :: tr(:)
    integer :: l, ne, e, k, i, ierr
    integer, allocatable :: fill(:)
    if (h%nlevel < 1 .or. nc /= finest_size(h)) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: a refinement of a grid of ' // itoa(nc) // ' nodes added to a ' // &
        'hierarchy whose finest grid has ' // itoa(finest_size(h)) // ' (expected mg_reset first)')
      return
    end if
    allocate (tr(h%nlevel + 1), stat=ierr)
    if (ierr /= 0) call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the hierarchy')
    if (ierr /= 0) return
    do l = 2, h%nlevel
      call move_transfer(h%transfer(l), tr(l))
    end do
    call move_alloc(tr, h%transfer)
    h%nlevel = h%nlevel + 1
    ne = size(edge_nodes, 2)
    associate (t => h%transfer(h%nlevel))
      t%nc = nc
      t%nf = nc + ne
      allocate (t%ends(2, ne), t%cptr(nc + 1), t%child(nc + 2 * ne), fill(nc), stat=ierr)
      if (ierr /= 0) then
        call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the prolongation of ' // itoa(t%nf) // ' nodes')
        return
      end if
      t%ends = edge_nodes
      fill = 1
      do e = 1, ne
        fill(edge_nodes(:, e)) = fill(edge_nodes(:, e)) + 1
      end do
      t%cptr(1) = 1
      do i = 1, nc
        t%cptr(i + 1) = t%cptr(i) + fill(i)
        t%child(t%cptr(i)) = i
      end do
      fill = 1
      do e = 1, ne
        do k = 1, 2
          i = edge_nodes(k, e)
          t%child(t%cptr(i) + fill(i)) = nc + e
          fill(i) = fill(i) + 1
        end do
      end do
    end associate
  end subroutine mg_add_level

  !> Nodes of the finest grid of the hierarchy (0 without one).
  pure integer function mg_finest_size(h) result(n)
    type(mg_hierarchy_t), intent(in) :: h
    n = finest_size(h)
  end function mg_finest_size

  !> Nodes of the finest grid of the hierarchy (0 without one).
  pure integer function finest_size(h) result(n)
    type(mg_hierarchy_t), intent(in) :: h
    n = 0
    if (h%nlevel == 1) n = h%n1
    if (h%nlevel >= 2) n = h%transfer(h%nlevel)%nf
  end function finest_size

  !> tb = ta, ta emptied (no copy of the arrays).
  subroutine move_transfer(ta, tb)
    type(mg_transfer_t), intent(inout) :: ta
    type(mg_transfer_t), intent(inout) :: tb
    tb%nc = ta%nc
    tb%nf = ta%nf
    call move_alloc(ta%ends, tb%ends)
    call move_alloc(ta%cptr, tb%cptr)
    call move_alloc(ta%child, tb%child)
    tb%algebraic = ta%algebraic
    call rect_move(ta%p, tb%p)
    call rect_move(ta%pt, tb%pt)
    if (allocated(ta%agg)) call move_alloc(ta%agg, tb%agg)
  end subroutine move_transfer

  !> Replace h by an algebraic hierarchy of the matrix a (smoothed aggregation,
  !> dualsig_amg_aggregation) for a mesh without a hierarchy of refinements: grids are
  !> aggregated until one has at most amg_coarsest_max unknowns (at least one coarse grid
  !> when a%n > 1); grid l-1's operator is P^T A_l P, later truncated by the solve.
  !> xy (2, a%n): the coordinates of the unknowns, when they are mesh nodes: the finest
  !> aggregation then visits them row by row (amg_sweep_order), whatever their numbering;
  !> without xy, in their numbering (coarse grids always in theirs, which follows the
  !> finer sweep).
  !> st: DS_ERR_MEMORY; DS_ERR_NUMERIC when the matrix cannot be coarsened at all.
  subroutine mg_build_algebraic(h, a, st, xy)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: xy(:,:)
    type(mg_transfer_t), allocatable :: tr(:)
    type(csr_t), allocatable :: ops(:)
    integer, allocatable :: order(:)
    integer :: nb, k, l, n, ierr
    call mg_clear(h)
    if (present(xy)) then
      if (size(xy, 2) /= a%n) then
        call set_error(st, DS_ERR_NUMERIC, 'multigrid: ' // itoa(size(xy, 2)) // ' coordinates for a matrix of order ' &
                       // itoa(a%n))
        return
      end if
      call amg_sweep_order(xy, order, st)
      if (.not. is_ok(st)) return
    end if
    allocate (tr(amg_max_grids), ops(amg_max_grids), stat=ierr)   ! small: descriptors
    if (ierr /= 0) call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the hierarchy')
    if (ierr /= 0) return
    nb = 0
    n = a%n
    do while (nb < amg_max_grids - 1 .and. (n > amg_coarsest_max .or. nb == 0) .and. n > 1)
      if (nb == 0) then
        call algebraic_grid(a, tr(nb + 1), ops(nb + 1), st, order)
      else
        call algebraic_grid(ops(nb), tr(nb + 1), ops(nb + 1), st)
      end if
      if (.not. is_ok(st)) return
      if (real(tr(nb + 1)%nc, dp) > amg_min_coarsening * n) exit
      nb = nb + 1
      n = tr(nb)%nc
    end do
    if (nb == 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: the aggregation does not coarsen a matrix of order ' // itoa(a%n))
      return
    end if
    h%nlevel = nb + 1
    h%n1 = n
    allocate (h%transfer(nb + 1), h%grid(nb), stat=ierr)   ! small: descriptors
    if (ierr /= 0) call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the hierarchy')
    if (ierr /= 0) return
    do k = 1, nb                     ! built finest first: transfer k maps grid nb+1-k to nb+2-k
      l = nb + 2 - k
      call move_transfer(tr(k), h%transfer(l))
      call csr_move(ops(k), h%grid(l - 1)%a)
      n = h%grid(l - 1)%a%n
      allocate (h%grid(l - 1)%x(n), h%grid(l - 1)%b(n), h%grid(l - 1)%r(n), stat=ierr)
      if (ierr /= 0) call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse vectors')
      if (ierr /= 0) return
    end do
  end subroutine mg_build_algebraic

  !> dst = the grids of src (each transfer as a general sparse prolongation) and one finer
  !> grid whose prolongation from src's finest grid is p (p%m x p%n, p%n the finest size of
  !> src): e.g. P1 -> P2 of the finest mesh composed with a change of basis on the P2
  !> unknowns (the stream function of the P2 dual, dualsig_dual_p2_stream).  The aggregate
  !> of a fine node (restrict_bounds) is the coarse node of its largest weight.  src is not
  !> changed; p is moved into dst (empty on return: the finest prolongation is not held
  !> twice); dst's coarse operators are built by its first solve.
  !> st: DS_ERR_INPUT (src without a grid, p of the wrong width), DS_ERR_MEMORY.
  subroutine mg_extend_algebraic(src, p, dst, st)
    type(mg_hierarchy_t), intent(in) :: src
    type(rect_t), intent(inout) :: p
    type(mg_hierarchy_t), intent(inout) :: dst
    type(status_t), intent(out) :: st
    integer :: l, ierr
    call mg_clear(dst)
    if (src%nlevel < 1 .or. p%n /= finest_size(src)) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: a prolongation of width ' // itoa(p%n) // ' added to a hierarchy ' // &
        'whose finest grid has ' // itoa(finest_size(src)) // ' nodes')
      return
    end if
    allocate (dst%transfer(src%nlevel + 1), stat=ierr)   ! small: descriptors
    if (ierr /= 0) call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the hierarchy')
    if (ierr /= 0) return
    dst%nlevel = src%nlevel + 1
    dst%n1 = src%n1
    do l = 2, src%nlevel
      associate (ts => src%transfer(l), td => dst%transfer(l))
        if (ts%algebraic) then
          td%p = ts%p
        else
          call red_prolongation(ts, td%p, st)
        end if
        if (is_ok(st)) call general_transfer(td, st)
      end associate
      if (.not. is_ok(st)) return
    end do
    call rect_move(p, dst%transfer(dst%nlevel)%p)
    call general_transfer(dst%transfer(dst%nlevel), st)
  end subroutine mg_extend_algebraic

  !> mg_extend_algebraic for a src that is not needed afterwards (src emptied): its
  !> prolongations are moved into dst instead of copied, and src's transposes are freed
  !> before dst's are made, so the two are never held at once.  a_src (optional): the
  !> operator of src's finest grid, e.g. p^T A p for the matrix A of dst's first solve; with
  !> it, src's coarse operators (built by mg_build_algebraic from a_src) and a_src itself
  !> are moved into dst as its coarse operators, which that solve then takes instead of
  !> recomputing every Galerkin product (values_fresh: identical values, since they are the
  !> same products of the same matrices).  st: as mg_extend_algebraic.
  subroutine mg_extend_algebraic_take(src, p, dst, st, a_src)
    type(mg_hierarchy_t), intent(inout) :: src
    type(rect_t), intent(inout) :: p
    type(mg_hierarchy_t), intent(inout) :: dst
    type(status_t), intent(out) :: st
    type(csr_t), intent(inout), optional :: a_src
    integer :: l, ierr
    logical :: ops, general
    general = src%nlevel < 1 .or. p%n /= finest_size(src)
    if (.not. general) general = .not. all(src%transfer(2:src%nlevel)%algebraic)   ! (transfer allocated)
    if (general) then
      call mg_extend_algebraic(src, p, dst, st)       ! (refusal, or red transfers: made anew)
      call mg_clear(src)
      return
    end if
    call mg_clear(dst)
    ops = present(a_src) .and. allocated(src%grid)
    if (ops) ops = size(src%grid) == src%nlevel - 1 .and. a_src%n == p%n
    allocate (dst%transfer(src%nlevel + 1), stat=ierr)   ! small: descriptors
    if (ierr == 0 .and. ops) allocate (dst%grid(src%nlevel), stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the hierarchy')
      return
    end if
    dst%nlevel = src%nlevel + 1
    dst%n1 = src%n1
    do l = 2, src%nlevel
      call rect_move(src%transfer(l)%p, dst%transfer(l)%p)
    end do
    if (ops) then
      do l = 1, src%nlevel - 1
        call move_grid(src%grid(l), dst%grid(l))
      end do
      call csr_move(a_src, dst%grid(src%nlevel)%a)
      associate (g => dst%grid(src%nlevel))
        allocate (g%x(g%a%n), g%b(g%a%n), g%r(g%a%n), stat=ierr)
      end associate
      if (alloc_failed(ierr, st, 'the vectors of a coarse grid', 3_i8 * p%n, BYTES_REAL)) return
    end if
    call mg_clear(src)                                ! its transposes, before new ones
    call rect_move(p, dst%transfer(dst%nlevel)%p)
    do l = 2, dst%nlevel
      call general_transfer(dst%transfer(l), st)
      if (.not. is_ok(st)) return
    end do
    dst%values_fresh = ops
  end subroutine mg_extend_algebraic_take

  !> gb = ga, ga emptied (no copy of the arrays).
  subroutine move_grid(ga, gb)
    type(mg_grid_t), intent(inout) :: ga, gb
    call csr_move(ga%a, gb%a)
    if (allocated(ga%x)) call move_alloc(ga%x, gb%x)
    if (allocated(ga%b)) call move_alloc(ga%b, gb%b)
    if (allocated(ga%r)) call move_alloc(ga%r, gb%r)
  end subroutine move_grid

  !> The transfer t with t%p set: t%pt, the sizes and the aggregates (largest weight).
  subroutine general_transfer(t, st)
    type(mg_transfer_t), intent(inout) :: t
    type(status_t), intent(inout) :: st
    integer :: i, ist
    t%algebraic = .true.
    t%nf = t%p%m
    t%nc = t%p%n
    call amg_transpose(t%p, t%pt, st)
    if (.not. is_ok(st)) return
    allocate (t%agg(t%nf), stat=ist)
    if (alloc_failed(ist, st, 'the aggregates of a grid', t%nf, BYTES_INT)) return
    do i = 1, t%nf
      t%agg(i) = 1
      if (t%p%rowptr(i + 1) > t%p%rowptr(i)) &
        t%agg(i) = t%p%col(t%p%rowptr(i) - 1 + maxloc(abs(t%p%val(t%p%rowptr(i):t%p%rowptr(i + 1) - 1)), 1))
    end do
  end subroutine general_transfer

  !> Free the transposes P^T of the algebraic transfers (restrict then works through the
  !> rows of P, rect_matvec_t; ensure_transpose rebuilds one where a Galerkin product needs
  !> it): for a linear solve by CG, whose extra vectors would otherwise make the peak.
  subroutine drop_transposes(h)
    type(mg_hierarchy_t), intent(inout) :: h
    integer :: l
    do l = 2, h%nlevel
      associate (t => h%transfer(l))
        if (.not. t%algebraic) cycle
        if (allocated(t%pt%rowptr)) deallocate (t%pt%rowptr)
        if (allocated(t%pt%col)) deallocate (t%pt%col)
        if (allocated(t%pt%val)) deallocate (t%pt%val)
      end associate
    end do
  end subroutine drop_transposes

  !> t%pt = t%p^T for an algebraic transfer whose transpose was dropped (drop_transposes).
  subroutine ensure_transpose(t, st)
    type(mg_transfer_t), intent(inout) :: t
    type(status_t), intent(inout) :: st
    if (.not. t%algebraic .or. allocated(t%pt%val)) return
    call amg_transpose(t%p, t%pt, st)
  end subroutine ensure_transpose

  !> The prolongation of a red refinement (module header) as a sparse matrix.
  subroutine red_prolongation(t, p, st)
    type(mg_transfer_t), intent(in) :: t
    type(rect_t), intent(out) :: p
    type(status_t), intent(inout) :: st
    integer :: i, e, ist
    p%m = t%nf
    p%n = t%nc
    allocate (p%rowptr(t%nf + 1), p%col(t%nc + 2 * (t%nf - t%nc)), p%val(t%nc + 2 * (t%nf - t%nc)), stat=ist)
    if (alloc_failed(ist, st, 'a prolongation', 3_i8 * t%nf, BYTES_REAL)) return
    p%rowptr(1) = 1
    do i = 1, t%nc
      p%col(i) = i
      p%val(i) = 1.0_dp
      p%rowptr(i + 1) = i + 1
    end do
    do e = 1, t%nf - t%nc
      i = t%nc + 2 * e - 1
      p%col(i:i + 1) = [minval(t%ends(:, e)), maxval(t%ends(:, e))]
      p%val(i:i + 1) = 0.5_dp
      p%rowptr(t%nc + e + 1) = i + 2
    end do
  end subroutine red_prolongation

  !> One algebraic grid below the operator af: the transfer t (P by smoothed aggregation
  !> and P^T) and the coarse operator ac = P^T af P.
  !> order: the visiting order of the aggregation (absent, or an unallocated actual
  !> argument: the numbering).
  subroutine algebraic_grid(af, t, ac, st, order)
    type(csr_t), intent(in) :: af
    type(mg_transfer_t), intent(inout) :: t
    type(csr_t), intent(inout) :: ac
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: order(:)
    call amg_prolongation(af, t%p, t%agg, st, order)
    if (is_ok(st)) call amg_transpose(t%p, t%pt, st)
    if (is_ok(st)) call amg_galerkin_product(t%p, t%pt, af, ac, st)
    if (.not. is_ok(st)) return
    t%algebraic = .true.
    t%nf = af%n
    t%nc = t%p%n
  end subroutine algebraic_grid

  !> TNNMG (module header) from the start x (projected on the constraints first) on the
  !> finest grid of h, whose matrix is a.  On return x is the last iterate.
  !> st: DS_ERR_INPUT (no hierarchy of at least two grids, sizes), DS_ERR_NUMERIC (non-finite
  !> iterate, out of memory), DS_WARN_NOT_CONVERGED at max_iter.
  recursive subroutine multigrid_solve(h, a, f, kind, bnd, x, settings, res, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(mg_settings_t), intent(in) :: settings
    type(mg_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), allocatable :: r(:), v(:)
    logical, allocatable :: frozen(:), frozen_prev(:)
    real(dp) :: den
    integer :: n, ierr, nchanged, k

    call check_input(h, a, f, kind, bnd, x, settings, st)
    if (.not. is_ok(st)) return
    n = a%n
    res%grids = h%nlevel
    allocate (r(n), v(n), frozen(n), stat=ierr)
    if (ierr == 0) call setup_grids(h, a, .false., ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for ' // itoa(n) // ' unknowns')
      return
    end if
    if (settings%fmg_cycles > 0 .and. h%nlevel >= 3) then
      if (all(x == 0.0_dp)) call fmg_start(h, a, f, kind, bnd, x, settings, ierr)
      if (ierr /= 0) then
        h%values_fresh = .false.
        call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the nested start on the coarser grids')
        return
      end if
    end if
    where (kind == BOUND_FIXED) x = bnd
    where (kind == BOUND_LOWER) x = max(x, bnd)
    den = kkt_scale(a, f, kind, bnd)
    if (settings%krylov .and. all(kind == BOUND_FREE)) then
      frozen = .false.
      call galerkin_all(h, a, frozen, st)
      if (is_ok(st)) call drop_transposes(h)         ! CG holds more vectors: restrict through P
      if (is_ok(st)) call pcg_linear(h, a, f, x, settings, den, r, v, frozen, res, st)
      h%values_fresh = .false.
      return
    end if
    allocate (frozen_prev(n), stat=ierr)                ! (not needed by pcg_linear)
    if (ierr /= 0) then
      h%values_fresh = .false.
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for ' // itoa(n) // ' unknowns')
      return
    end if
    frozen_prev = .false.
    do
      do k = 1, settings%sweeps
        call sweep_projected(a, f, kind, bnd, x, mod(k, 2) == 1)
      end do
      call residual_kkt(a, f, kind, bnd, x, frozen_prev, r, frozen, res%kkt_residual, nchanged)
      if (den > 0.0_dp) res%kkt_residual = res%kkt_residual / den
      if (.not. (res%kkt_residual <= huge(1.0_dp))) then
        call set_error(st, DS_ERR_NUMERIC, 'multigrid: the iterate is no longer finite')
        exit
      end if
      res%converged = res%kkt_residual <= settings%tol
      if (res%converged .or. res%iterations >= settings%max_iter) exit
      res%iterations = res%iterations + 1
      if (res%iterations == 1) then
        call galerkin_all(h, a, frozen, st)
      else if (nchanged > 0) then
        call galerkin_update(h, a, frozen, frozen_prev, st)
      end if
      if (.not. is_ok(st)) exit
      if (res%iterations == 1 .or. nchanged > 0) res%galerkin_updates = res%galerkin_updates + 1
      frozen_prev = frozen
      call coarse_correction(h, frozen, r, v, settings%coarse_sweeps)
      call line_search(h, a, kind, bnd, r, v, x)
      do k = 1, settings%sweeps
        call sweep_projected(a, f, kind, bnd, x, mod(k, 2) == 0)
      end do
    end do
    h%values_fresh = .false.          ! set for this solve's matrix only (a solve may end first)
    if (.not. is_ok(st)) then
      res%kkt_residual = huge(1.0_dp)
      return
    end if
    res%kkt_residual = kkt_residual(a, f, kind, bnd, x, r)
    res%converged = res%kkt_residual <= settings%tol
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'multigrid: not converged after ' // &
      itoa(res%iterations) // ' iterations (KKT residual above the tolerance)')
  end subroutine multigrid_solve

  !> A x = f (no bounds) by conjugate gradients from x, preconditioned by one symmetric
  !> V-cycle (pcg_vcycle), for multigrid_solve with settings%krylov; den = kkt_scale, the
  !> size of the data.  A V-cycle
  !> that contracts the energy error by q per cycle makes a condition number of about
  !> (1 + sqrt q) / (1 - sqrt q) for CG, whose rate sqrt(kappa) - 1 / (sqrt(kappa) + 1) is
  !> well below sqrt q when q is not small (the aggregation grids of an adaptive step: q about
  !> 0.4).  Stops at the relative residual settings%tol or by the energy stop: a CG step
  !> lowers J by alpha r^T z / 2 exactly, so the decreases come without extra work.
  !> r, z, frozen: work vectors of the matrix's order (frozen all .false.).
  subroutine pcg_linear(h, a, f, x, settings, den, r, z, frozen, res, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    real(dp), intent(inout) :: x(:)
    type(mg_settings_t), intent(in) :: settings
    real(dp), intent(in) :: den
    real(dp), intent(inout) :: r(:), z(:)
    logical, intent(in) :: frozen(:)
    type(mg_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: p(:), q(:), w2(:)
    real(dp) :: rz, rz_new, alpha, delta, delta_prev, ratio_prev, ratio
    integer :: ierr
    ! q = A p is dead once r is updated: it is the V-cycle's first work vector too
    allocate (p(a%n), q(a%n), w2(a%n), stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for ' // itoa(a%n) // ' unknowns')
      return
    end if
    call csr_matvec(a, x, r)
    r = f - r
    res%kkt_residual = norm_ratio(r, den)
    res%converged = res%kkt_residual <= settings%tol
    if (res%converged) return
    call pcg_vcycle(h, a, r, z, q, w2, frozen, settings)
    p = z
    rz = dot_product(r, z)
    delta_prev = -1.0_dp
    ratio_prev = -1.0_dp
    if (settings%energy_tol > 0.0_dp) res%energy_gap = huge(1.0_dp)
    do while (res%iterations < settings%max_iter)
      res%iterations = res%iterations + 1
      call csr_matvec(a, p, q)
      alpha = rz / dot_product(p, q)
      if (.not. (abs(alpha) <= huge(1.0_dp))) then
        call set_error(st, DS_ERR_NUMERIC, 'multigrid: conjugate gradients broke down (p^T A p is not positive)')
        return
      end if
      x = x + alpha * p
      r = r - alpha * q
      res%kkt_residual = norm_ratio(r, den)
      res%converged = res%kkt_residual <= settings%tol
      if (settings%energy_tol > 0.0_dp .and. .not. res%converged) then
        delta = 0.5_dp * alpha * rz                  ! J(x_old) - J(x_new)
        if (delta_prev > 0.0_dp) then
          ratio = delta / delta_prev
          res%energy_gap = predicted_gap(delta, ratio, ratio_prev)
          ratio_prev = ratio
        end if
        delta_prev = delta
        res%energy_stop = res%energy_gap <= settings%energy_tol
        res%converged = res%energy_stop
      end if
      if (res%converged) exit
      call pcg_vcycle(h, a, r, z, q, w2, frozen, settings)
      rz_new = dot_product(r, z)
      p = z + (rz_new / rz) * p
      rz = rz_new
    end do
    call csr_matvec(a, x, r)                         ! the true residual of the returned x
    r = f - r
    res%kkt_residual = norm_ratio(r, den)
    res%converged = res%kkt_residual <= settings%tol .or. res%energy_stop
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'multigrid: not converged after ' // &
      itoa(res%iterations) // ' conjugate-gradient iterations (residual above the tolerance)')
  end subroutine pcg_linear

  !> ||r|| / den (den = 0: ||r||).
  pure real(dp) function norm_ratio(r, den) result(ratio)
    real(dp), intent(in) :: r(:), den
    ratio = norm2(r)
    if (den > 0.0_dp) ratio = ratio / den
  end function norm_ratio

  !> z = B r, B one symmetric V-cycle for A from zero: settings%sweeps Gauss-Seidel sweeps
  !> (forward, backward, ...), the coarse correction (coarse_correction: a V-cycle with an odd
  !> number of sweeps per grid, symmetric, exact on grid 1), then the same sweeps in the
  !> adjoint order (the pre-smoothing's directions reversed and flipped), so B is symmetric
  !> positive definite as CG needs.  w, w2: work vectors.
  subroutine pcg_vcycle(h, a, r, z, w, w2, frozen, settings)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: z(:)
    real(dp), intent(inout) :: w(:), w2(:)
    logical, intent(in) :: frozen(:)
    type(mg_settings_t), intent(in) :: settings
    integer :: k, n
    n = settings%sweeps
    z = 0.0_dp
    do k = 1, n
      call csr_gauss_seidel(a, r, z, mod(k, 2) == 1)
    end do
    call csr_matvec(a, z, w)
    w = r - w
    call coarse_correction(h, frozen, w, w2, pcg_coarse_sweeps(settings%coarse_sweeps))
    z = z + w2
    do k = 1, n
      call csr_gauss_seidel(a, r, z, mod(n - k + 1, 2) /= 1)
    end do
  end subroutine pcg_vcycle

  !> The sweeps per coarse grid of a symmetric V-cycle: coarse_correction's V-cycle is
  !> symmetric for an odd number (its post-sweeps are the adjoint of its pre-sweeps then).
  pure integer function pcg_coarse_sweeps(nu) result(n)
    integer, intent(in) :: nu
    n = max(1, nu)
    if (mod(n, 2) == 0) n = n + 1
  end function pcg_coarse_sweeps

  !> The energy stop's prediction of J - J* from the last decrease delta and the last two
  !> ratios of decreases (ratio_prev < 0: not known yet): delta q / (1 - q), q the larger
  !> ratio, at least energy_ratio_min; huge when q >= energy_ratio_max.
  pure real(dp) function predicted_gap(delta, ratio, ratio_prev) result(gap)
    real(dp), intent(in) :: delta, ratio, ratio_prev
    real(dp) :: q
    gap = huge(1.0_dp)
    q = ratio
    if (ratio_prev > 0.0_dp) q = max(q, ratio_prev)
    if (q >= energy_ratio_max) return
    q = max(q, energy_ratio_min)
    gap = delta * q / (1.0_dp - q)
  end function predicted_gap

  !> A start for a cold solve by nested iteration inside the hierarchy (full multigrid):
  !> the QP restricted to grid l = 2..L-1 (the Galerkin operator P^T A P, the load P^T F,
  !> the bounds of the same nodes, grid l's nodes being nodes 1..n_l of every finer grid,
  !> or on algebraic grids those of the aggregates: restrict_bounds),
  !> solved by settings%fmg_cycles iterations on grids 1..l from the interpolated solution
  !> of grid l-1; x = the interpolation of grid L-1's.  Coarse solves that do not converge
  !> are expected (a start only); ierr /= 0: out of memory.
  recursive subroutine fmg_start(h, a, f, kind, bnd, x, settings, ierr)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(inout) :: x(:)
    type(mg_settings_t), intent(in) :: settings
    integer, intent(out) :: ierr
    type(csr_t), allocatable :: ops(:)
    type(mg_hierarchy_t) :: hs
    type(mg_settings_t) :: sub
    type(mg_result_t) :: rs
    type(status_t) :: st
    real(dp), allocatable :: fl(:,:), bl(:,:), xl(:), xc(:)
    integer, allocatable :: kl(:,:)
    logical, allocatable :: none(:)
    integer :: l, lv, nl, top
    top = h%nlevel
    call setup_grids(h, a, .false., ierr)
    if (ierr == 0) allocate (none(a%n), source=.false., stat=ierr)
    if (ierr == 0) allocate (ops(top - 1), stat=ierr)
    if (ierr /= 0) return
    call galerkin_all(h, a, none, st)          ! untruncated: P^T A P on every grid
    deallocate (none)
    if (.not. is_ok(st)) return
    do l = 2, top - 1
      ops(l) = h%grid(l)%a
    end do
    allocate (fl(h%transfer(top)%nc, top - 1), bl(h%transfer(top)%nc, top - 1), source=0.0_dp, stat=ierr)
    if (ierr == 0) allocate (kl(h%transfer(top)%nc, top - 1), source=BOUND_FREE, stat=ierr)
    if (ierr /= 0) return
    call restrict(h%transfer(top), f, fl(:, top - 1))
    call restrict_bounds(h%transfer(top), kind, bnd, kl(:, top - 1), bl(:, top - 1))
    do l = top - 1, 3, -1
      nl = h%transfer(l)%nf
      call restrict(h%transfer(l), fl(1:nl, l), fl(1:h%transfer(l)%nc, l - 1))
      call restrict_bounds(h%transfer(l), kl(1:nl, l), bl(1:nl, l), kl(1:h%transfer(l)%nc, l - 1), &
                           bl(1:h%transfer(l)%nc, l - 1))
    end do
    sub = settings
    sub%max_iter = settings%fmg_cycles
    sub%fmg_cycles = 0
    allocate (xl(h%transfer(2)%nf), source=0.0_dp, stat=ierr)
    if (ierr /= 0) return
    do l = 2, top - 1
      nl = h%transfer(l)%nf
      if (l > 2) then
        call move_alloc(xl, xc)
        allocate (xl(nl), stat=ierr)
        if (ierr /= 0) return
        call prolong_set(h%transfer(l), xc, xl)
        deallocate (xc)
      end if
      hs%nlevel = l
      hs%n1 = h%n1
      allocate (hs%transfer(l))  ! small: one transfer descriptor per level
      do lv = 2, l
        call move_transfer(h%transfer(lv), hs%transfer(lv))
      end do
      call multigrid_solve(hs, ops(l), fl(1:nl, l), kl(1:nl, l), bl(1:nl, l), xl, sub, rs, st)
      do lv = 2, l
        call move_transfer(hs%transfer(lv), h%transfer(lv))
      end do
      call mg_clear(hs)
      ops(l) = csr_t()
      if (.not. is_ok(st)) return                ! (a numeric failure: the cold start stays)
    end do
    call prolong_set(h%transfer(top), xl, x)
  end subroutine fmg_start

  !> The constraints of the QP restricted to the coarse grid of t: on a red refinement the
  !> coarse nodes' own (kc, bc = kf, bf of nodes 1..nc); on an algebraic grid those of the
  !> aggregate: fixed (at a fixed member's value) when a member is fixed, else bounded below by
  !> the largest bound of its bounded members (a constant above it is feasible), else free.
  pure subroutine restrict_bounds(t, kf, bf, kc, bc)
    type(mg_transfer_t), intent(in) :: t
    integer, intent(in) :: kf(:)
    real(dp), intent(in) :: bf(:)
    integer, intent(out) :: kc(:)
    real(dp), intent(out) :: bc(:)
    integer :: i, c
    if (.not. t%algebraic) then
      kc = kf(1:t%nc)
      bc = bf(1:t%nc)
      return
    end if
    kc = BOUND_FREE
    bc = -huge(1.0_dp)
    do i = 1, t%nf
      c = t%agg(i)
      if (kc(c) == BOUND_FIXED) cycle
      if (kf(i) == BOUND_FIXED) then
        kc(c) = BOUND_FIXED
        bc(c) = bf(i)
      else if (kf(i) == BOUND_LOWER) then
        kc(c) = BOUND_LOWER
        bc(c) = max(bc(c), bf(i))
      end if
    end do
    where (kc == BOUND_FREE) bc = 0.0_dp
  end subroutine restrict_bounds

  !> The checks of multigrid_solve's arguments.
  subroutine check_input(h, a, f, kind, bnd, x, settings, st)
    type(mg_hierarchy_t), intent(in) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:), x(:)
    integer, intent(in) :: kind(:)
    type(mg_settings_t), intent(in) :: settings
    type(status_t), intent(out) :: st
    if (h%nlevel < 2) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: no grid hierarchy (expected at least one uniform refinement of ' // &
        'the coarse mesh, levels >= 2)')
    else if (a%n /= finest_size(h)) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: the matrix has order ' // itoa(a%n) // ', the finest grid ' // &
        itoa(finest_size(h)) // ' nodes')
    else if (size(f) /= a%n .or. size(kind) /= a%n .or. size(bnd) /= a%n .or. size(x) /= a%n) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: F, kind, bnd and x must have the order of the matrix')
    else if (settings%max_iter < 0 .or. .not. settings%tol >= 0.0_dp .or. settings%sweeps < 0 .or. &
             settings%coarse_sweeps < 0) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: need max_iter >= 0, tol >= 0, sweeps >= 0 and coarse_sweeps >= 0')
    else if (any(a%val(a%diag) <= 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: the matrix has a non-positive diagonal entry')
    end if
  end subroutine check_input

  !> In one pass: r = F - A x, the unscaled KKT residual of dualsig_qp_types (`kkt`, to be
  !> divided by ||F||), the frozen unknowns (fixed, or bounded and at the bound) and how many
  !> of them differ from `frozen_prev`.
  pure subroutine residual_kkt(a, f, kind, bnd, x, frozen_prev, r, frozen, kkt, nchanged)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:), x(:)
    logical, intent(in) :: frozen_prev(:)
    real(dp), intent(out) :: r(:)
    logical, intent(out) :: frozen(:)
    real(dp), intent(out) :: kkt
    integer, intent(out) :: nchanged
    type(norm_acc_t) :: num
    real(dp) :: g, s
    integer :: i, p
    nchanged = 0
    do i = 1, a%n
      s = f(i)
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        s = s - a%val(p) * x(a%col(p))
      end do
      r(i) = s
      select case (kind(i))
      case (BOUND_FREE)
        g = -s
        frozen(i) = .false.
      case (BOUND_LOWER)
        g = min(-s, a%val(a%diag(i)) * (x(i) - bnd(i)))
        frozen(i) = x(i) <= bnd(i)
      case default
        g = 0.0_dp
        frozen(i) = .true.
      end select
      call norm_acc_add(num, g)
      if (frozen(i) .neqv. frozen_prev(i)) nchanged = nchanged + 1
    end do
    kkt = norm_acc_value(num)
  end subroutine residual_kkt

  !> The coarse operators' patterns and the vectors of grids 1..L-1 (once per hierarchy).
  !> The pattern of P^T A P is the edge graph of the coarse mesh when A has the pattern of
  !> the P1 elements of the fine mesh (red refinement couples only nodes of one coarse
  !> triangle); `general` builds it from the product instead, for any A.
  subroutine setup_grids(h, a, general, ierr)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    logical, intent(in) :: general
    integer, intent(out) :: ierr
    integer :: l, nc
    type(status_t) :: st
    ierr = 0
    if (allocated(h%grid) .and. .not. general) then
      if (size(h%grid) == h%nlevel - 1) return
    end if
    if (allocated(h%grid)) deallocate (h%grid)
    h%coarse_ok = .false.
    h%values_fresh = .false.
    allocate (h%grid(h%nlevel - 1), stat=ierr)
    if (ierr /= 0) return
    do l = h%nlevel, 2, -1
      nc = h%transfer(l)%nc
      if (h%transfer(l)%algebraic) then
        call ensure_transpose(h%transfer(l), st)
        if (.not. is_ok(st)) ierr = 1
        if (ierr /= 0) return
        if (l == h%nlevel) call amg_galerkin_product(h%transfer(l)%p, h%transfer(l)%pt, a, h%grid(l - 1)%a, st)
        if (l < h%nlevel) call amg_galerkin_product(h%transfer(l)%p, h%transfer(l)%pt, h%grid(l)%a, h%grid(l - 1)%a, st)
        if (.not. is_ok(st)) ierr = 1
      else if (.not. general) then
        call csr_pattern_from_edges(nc, coarse_edges(h, l), h%grid(l - 1)%a, st=st)
        if (.not. is_ok(st)) ierr = 1
      else if (l == h%nlevel) then
        call galerkin_pattern(h%transfer(l), a, h%grid(l - 1)%a, ierr)
      else
        call galerkin_pattern(h%transfer(l), h%grid(l)%a, h%grid(l - 1)%a, ierr)
      end if
      if (ierr /= 0) return
      allocate (h%grid(l - 1)%x(nc), h%grid(l - 1)%b(nc), h%grid(l - 1)%r(nc), stat=ierr)
      if (ierr /= 0) return
    end do
    h%values_fresh = all(h%transfer(2:h%nlevel)%algebraic)
  end subroutine setup_grids

  !> The edges of grid l-1: the ends of the midpoints of transfer(l).
  pure function coarse_edges(h, l) result(edges)
    type(mg_hierarchy_t), intent(in) :: h
    integer, intent(in) :: l
    integer :: edges(2, h%transfer(l)%nf - h%transfer(l)%nc)
    edges = h%transfer(l)%ends
  end function coarse_edges

  !> The pattern of P^T A P for the prolongation of `t` (values zero, columns sorted).
  subroutine galerkin_pattern(t, af, ac, ierr)
    type(mg_transfer_t), intent(in) :: t
    type(csr_t), intent(in) :: af
    type(csr_t), intent(out) :: ac
    integer, intent(out) :: ierr
    integer, allocatable :: mark(:), list(:)
    integer :: pass, ci, q, p, j, k, jc, cnt, nnz, lo
    allocate (mark(t%nc), list(t%nc), ac%rowptr(t%nc + 1), ac%diag(t%nc), stat=ierr)
    if (ierr /= 0) return
    ac%n = t%nc
    do pass = 1, 2
      mark = 0
      nnz = 0
      ac%rowptr(1) = 1
      do ci = 1, t%nc
        cnt = 0
        do q = t%cptr(ci), t%cptr(ci + 1) - 1
          do p = af%rowptr(t%child(q)), af%rowptr(t%child(q) + 1) - 1
            j = af%col(p)
            do k = 1, merge(1, 2, j <= t%nc)
              jc = parent(t, j, k)
              if (mark(jc) /= ci) then
                mark(jc) = ci
                cnt = cnt + 1
                list(cnt) = jc
              end if
            end do
          end do
        end do
        lo = nnz
        nnz = nnz + cnt
        ac%rowptr(ci + 1) = nnz + 1
        if (pass == 2) call csr_set_row_pattern(ac, ci, lo, list(1:cnt))
      end do
      if (pass == 1) then
        allocate (ac%col(nnz), ac%val(nnz), stat=ierr)
        if (ierr /= 0) return
        ac%val = 0.0_dp
      end if
    end do
  end subroutine galerkin_pattern

  !> The k-th coarse parent of fine node j (k = 1 only for a coarse node).
  pure integer function parent(t, j, k)
    type(mg_transfer_t), intent(in) :: t
    integer, intent(in) :: j, k
    if (j <= t%nc) then
      parent = j
    else
      parent = t%ends(k, j - t%nc)
    end if
  end function parent

  !> Row ci of ac = P_T^T af P_T on the pattern of galerkin_pattern, P_T the prolongation
  !> with the rows of the frozen fine unknowns zeroed (frozen absent: none).  pos(nc) is
  !> scratch.
  pure subroutine galerkin_row(t, af, frozen, ac, pos, ci, ok)
    type(mg_transfer_t), intent(in) :: t
    type(csr_t), intent(in) :: af
    logical, intent(in), optional :: frozen(:)
    type(csr_t), intent(inout) :: ac
    integer, intent(inout) :: pos(:)             !! zero on entry and on return
    integer, intent(in) :: ci
    logical, intent(inout) :: ok                !! set .false. when an entry is outside the pattern
    integer :: q, p, i, j, e, lo, hi, p1, p2, nc
    real(dp) :: wi, aij
    logical :: truncated
    lo = ac%rowptr(ci)
    hi = ac%rowptr(ci + 1) - 1
    nc = t%nc
    truncated = present(frozen)
    do p = lo, hi
      pos(ac%col(p)) = p
    end do
    ac%val(lo:hi) = 0.0_dp
    do q = t%cptr(ci), t%cptr(ci + 1) - 1
      i = t%child(q)
      wi = 0.5_dp
      if (i <= nc) wi = 1.0_dp
      if (truncated) then
        if (frozen(i)) cycle
      end if
      do p = af%rowptr(i), af%rowptr(i + 1) - 1
        j = af%col(p)
        if (truncated) then
          if (frozen(j)) cycle
        end if
        aij = wi * af%val(p)
        if (j <= nc) then
          p1 = pos(j)
          if (p1 == 0) ok = .false.
          if (p1 == 0) exit
          ac%val(p1) = ac%val(p1) + aij
        else
          e = j - nc
          p1 = pos(t%ends(1, e))
          p2 = pos(t%ends(2, e))
          if (p1 == 0 .or. p2 == 0) ok = .false.
          if (p1 == 0 .or. p2 == 0) exit
          ac%val(p1) = ac%val(p1) + 0.5_dp * aij
          ac%val(p2) = ac%val(p2) + 0.5_dp * aij
        end if
      end do
    end do
    do p = lo, hi
      pos(ac%col(p)) = 0
    end do
  end subroutine galerkin_row

  !> The rows of the coarse operators that change when the frozen set of the finest grid
  !> changes from frozen_prev to frozen: on grid L-1 the parents of the changed unknowns and
  !> of their neighbours, on each coarser grid the parents of the rows changed above (the
  !> changed entries stay within these rows and columns); then the factor of grid 1.
  subroutine galerkin_update(h, a, frozen, frozen_prev, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    logical, intent(in) :: frozen(:), frozen_prev(:)
    type(status_t), intent(out) :: st
    logical, allocatable :: mark(:), markc(:)
    integer, allocatable :: pos(:)
    integer :: l, i, ci, ierr
    logical :: ok
    if (h%transfer(h%nlevel)%algebraic) then
      call galerkin_algebraic(h, a, frozen, st, frozen_prev)
      return
    end if
    ok = .true.
    allocate (mark(a%n), stat=ierr)
    if (ierr == 0) allocate (pos(h%transfer(h%nlevel)%nc), source=0, stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse operators')
      return
    end if
    mark = .false.
    do i = 1, a%n
      if (frozen(i) .neqv. frozen_prev(i)) mark(a%col(a%rowptr(i):a%rowptr(i + 1) - 1)) = .true.
    end do
    do l = h%nlevel, 2, -1
      associate (t => h%transfer(l))
        allocate (markc(t%nc), stat=ierr)
        if (ierr /= 0) then
          call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse operators')
          return
        end if
        markc = mark(1:t%nc)
        do i = t%nc + 1, t%nf
          if (mark(i)) markc(t%ends(:, i - t%nc)) = .true.
        end do
        do ci = 1, t%nc
          if (.not. markc(ci)) cycle
          if (l == h%nlevel) then
            call galerkin_row(t, a, frozen, h%grid(l - 1)%a, pos, ci, ok)
          else
            call galerkin_row(t, h%grid(l)%a, ac=h%grid(l - 1)%a, pos=pos, ci=ci, ok=ok)
          end if
        end do
      end associate
      call move_alloc(markc, mark)
    end do
    if (.not. ok) then      ! the pattern was right at galerkin_all: cannot happen
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: a coarse operator left its pattern')
      return
    end if
    if (any(mark)) call factor_coarsest(h)
  end subroutine galerkin_update

  !> The factor of grid 1's operator, rows without unknowns given a unit diagonal (a
  !> refactorisation when a factor of its pattern is held); when the operator is only
  !> semi-definite the V-cycle uses Gauss-Seidel sweeps instead.
  subroutine factor_coarsest(h)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t) :: a1
    type(status_t) :: st
    integer :: i
    a1 = h%grid(1)%a
    do i = 1, a1%n
      if (a1%val(a1%diag(i)) <= 0.0_dp) a1%val(a1%diag(i)) = 1.0_dp
    end do
    if (h%coarse%n == a1%n) then            ! the same pattern: no new analysis (checked by refactor)
      call cholesky_refactor(a1, h%coarse, st)
      h%coarse_ok = is_ok(st)
      if (h%coarse_ok) return
    end if
    call cholesky_factor(a1, h%coarse, st, ORDERING_AMD)
    h%coarse_ok = is_ok(st)
    if (.not. h%coarse_ok) call cholesky_free(h%coarse)
  end subroutine factor_coarsest

  !> All coarse operators for the frozen unknowns of the finest grid, and the factor of
  !> grid 1.  When an operator leaves the edge pattern of setup_grids (A is not a P1
  !> matrix of the finest mesh) the patterns are rebuilt from the products.
  subroutine galerkin_all(h, a, frozen, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    logical, intent(in) :: frozen(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: pos(:)
    integer :: l, ci, ierr, attempt
    logical :: ok
    if (h%transfer(h%nlevel)%algebraic) then
      call galerkin_algebraic(h, a, frozen, st)
      return
    end if
    allocate (pos(h%transfer(h%nlevel)%nc), source=0, stat=ierr)
    do attempt = 1, 2
      if (ierr /= 0) exit
      ok = .true.
      do ci = 1, h%transfer(h%nlevel)%nc
        call galerkin_row(h%transfer(h%nlevel), a, frozen, h%grid(h%nlevel - 1)%a, pos, ci, ok)
      end do
      do l = h%nlevel - 1, 2, -1
        do ci = 1, h%transfer(l)%nc
          call galerkin_row(h%transfer(l), h%grid(l)%a, ac=h%grid(l - 1)%a, pos=pos, ci=ci, ok=ok)
        end do
      end do
      if (ok) exit
      call setup_grids(h, a, .true., ierr)
    end do
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse operators')
      return
    end if
    call factor_coarsest(h)
  end subroutine galerkin_all

  !> The coarse operators of an algebraic hierarchy for the frozen unknowns of the finest
  !> grid (P_T^T A P_T, then P^T A_l P below), and the factor of grid 1.  frozen_prev
  !> present: only the rows that change (on grid L-1 the aggregates reaching a changed
  !> unknown or a neighbour of one; below, those reaching a changed row or its neighbours).
  subroutine galerkin_algebraic(h, a, frozen, st, frozen_prev)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    logical, intent(in) :: frozen(:)
    type(status_t), intent(out) :: st
    logical, intent(in), optional :: frozen_prev(:)
    integer, allocatable :: pos(:)
    logical, allocatable :: mark(:), markc(:)
    integer :: l, i, ierr
    logical :: ok
    if (h%values_fresh .and. .not. present(frozen_prev) .and. .not. any(frozen)) then
      h%values_fresh = .false.                  ! setup_grids' products are these operators
      call factor_coarsest(h)
      return
    end if
    h%values_fresh = .false.
    do l = 2, h%nlevel
      call ensure_transpose(h%transfer(l), st)
      if (.not. is_ok(st)) return
    end do
    allocate (pos(h%transfer(h%nlevel)%nc), source=0, stat=ierr)
    if (ierr == 0 .and. present(frozen_prev)) allocate (mark(a%n), source=.false., stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse operators')
      return
    end if
    ok = .true.
    if (present(frozen_prev)) then
      do i = 1, a%n
        if (frozen(i) .neqv. frozen_prev(i)) mark(a%col(a%rowptr(i):a%rowptr(i + 1) - 1)) = .true.
      end do
    end if
    do l = h%nlevel, 2, -1
      associate (t => h%transfer(l))
        if (present(frozen_prev)) then
          allocate (markc(t%nc), source=.false., stat=ierr)
          if (ierr /= 0) then
            call set_error(st, DS_ERR_NUMERIC, 'multigrid: out of memory for the coarse operators')
            return
          end if
          do i = 1, t%nf
            if (mark(i)) markc(t%p%col(t%p%rowptr(i):t%p%rowptr(i + 1) - 1)) = .true.
          end do
          if (l == h%nlevel) then
            call amg_galerkin_values(t%p, t%pt, a, h%grid(l - 1)%a, pos, ok, frozen, markc)
          else
            call amg_galerkin_values(t%p, t%pt, h%grid(l)%a, h%grid(l - 1)%a, pos, ok, rows=markc)
          end if
          call neighbours_of(h%grid(l - 1)%a, markc, mark, st)
          if (.not. is_ok(st)) return
        else if (l == h%nlevel) then
          call amg_galerkin_values(t%p, t%pt, a, h%grid(l - 1)%a, pos, ok, frozen)
        else
          call amg_galerkin_values(t%p, t%pt, h%grid(l)%a, h%grid(l - 1)%a, pos, ok)
        end if
      end associate
    end do
    if (.not. ok) then
      call set_error(st, DS_ERR_INPUT, 'multigrid: the matrix does not have the pattern of its algebraic hierarchy')
      return
    end if
    if (present(frozen_prev)) then
      if (.not. any(mark)) return
    end if
    call factor_coarsest(h)
  end subroutine galerkin_algebraic

  !> mark = rows(i) or rows(j) for a neighbour j of i in a (size a%n; rows deallocated).
  subroutine neighbours_of(a, rows, mark, st)
    type(csr_t), intent(in) :: a
    logical, allocatable, intent(inout) :: rows(:)
    logical, allocatable, intent(inout) :: mark(:)
    type(status_t), intent(inout) :: st
    integer :: i, ist
    if (allocated(mark)) deallocate (mark)
    allocate (mark(a%n), stat=ist)
    if (alloc_failed(ist, st, 'a coarse grid mask', a%n, BYTES_LOGICAL)) return
    mark = rows
    do i = 1, a%n
      if (rows(i)) mark(a%col(a%rowptr(i):a%rowptr(i + 1) - 1)) = .true.
    end do
    deallocate (rows)
  end subroutine neighbours_of

  !> v = P_T (one V-cycle on grids L-1..1 for the restricted residual P_T^T r), zero at the
  !> frozen unknowns.
  subroutine coarse_correction(h, frozen, r, v, nu)
    type(mg_hierarchy_t), intent(inout) :: h
    integer, intent(in) :: nu
    logical, intent(in) :: frozen(:)
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: v(:)
    integer :: l
    l = h%nlevel
    v = merge(0.0_dp, r, frozen)
    call restrict(h%transfer(l), v, h%grid(l - 1)%b)
    call vcycle(h, l - 1, nu)
    call prolong_set(h%transfer(l), h%grid(l - 1)%x, v)
    where (frozen) v = 0.0_dp
  end subroutine coarse_correction

  !> x = (approximately) A_l^{-1} b on grid l from zero: V(1,1), symmetric Gauss-Seidel,
  !> exact on grid 1.
  recursive subroutine vcycle(h, l, nu)
    type(mg_hierarchy_t), intent(inout) :: h
    integer, intent(in) :: l, nu
    type(status_t) :: st
    integer :: k
    associate (g => h%grid(l))
      g%x = 0.0_dp
      if (l == 1) then
        if (h%coarse_ok) then
          call cholesky_solve(h%coarse, g%b, g%x, st)
          where (g%a%val(g%a%diag) <= 0.0_dp) g%x = 0.0_dp
          if (is_ok(st)) return
          g%x = 0.0_dp
        end if
        do k = 1, coarse_sweeps_fallback
          call csr_gauss_seidel(g%a, g%b, g%x, .true.)
          call csr_gauss_seidel(g%a, g%b, g%x, .false.)
        end do
        return
      end if
      do k = 1, nu
        call csr_gauss_seidel(g%a, g%b, g%x, mod(k, 2) == 1)
      end do
      call csr_matvec(g%a, g%x, g%r)
      g%r = g%b - g%r
      call restrict(h%transfer(l), g%r, h%grid(l - 1)%b)
      call vcycle(h, l - 1, nu)
      call prolong_add(h%transfer(l), h%grid(l - 1)%x, g%x)
      do k = 1, nu
        call csr_gauss_seidel(g%a, g%b, g%x, mod(k, 2) == 0)
      end do
    end associate
  end subroutine vcycle

  !> bc = P^T rf.
  pure subroutine restrict(t, rf, bc)
    type(mg_transfer_t), intent(in) :: t
    real(dp), intent(in) :: rf(:)
    real(dp), intent(out) :: bc(:)
    integer :: e
    if (t%algebraic) then
      if (allocated(t%pt%val)) then
        call rect_matvec(t%pt, rf, bc)
      else
        call rect_matvec_t(t%p, rf, bc)              ! the transpose not held (drop_transposes)
      end if
      return
    end if
    bc = rf(1:t%nc)
    do e = 1, t%nf - t%nc
      bc(t%ends(1, e)) = bc(t%ends(1, e)) + 0.5_dp * rf(t%nc + e)
      bc(t%ends(2, e)) = bc(t%ends(2, e)) + 0.5_dp * rf(t%nc + e)
    end do
  end subroutine restrict

  !> xf = P xc.
  pure subroutine prolong_set(t, xc, xf)
    type(mg_transfer_t), intent(in) :: t
    real(dp), intent(in) :: xc(:)
    real(dp), intent(out) :: xf(:)
    integer :: e
    if (t%algebraic) then
      call rect_matvec(t%p, xc, xf)
      return
    end if
    xf(1:t%nc) = xc
    do e = 1, t%nf - t%nc
      xf(t%nc + e) = 0.5_dp * (xc(t%ends(1, e)) + xc(t%ends(2, e)))
    end do
  end subroutine prolong_set

  !> xf = xf + P xc.
  pure subroutine prolong_add(t, xc, xf)
    type(mg_transfer_t), intent(in) :: t
    real(dp), intent(in) :: xc(:)
    real(dp), intent(inout) :: xf(:)
    integer :: e, i, p
    if (t%algebraic) then
      do i = 1, t%nf
        do p = t%p%rowptr(i), t%p%rowptr(i + 1) - 1
          xf(i) = xf(i) + t%p%val(p) * xc(t%p%col(p))
        end do
      end do
      return
    end if
    xf(1:t%nc) = xf(1:t%nc) + xc
    do e = 1, t%nf - t%nc
      xf(t%nc + e) = xf(t%nc + e) + 0.5_dp * (xc(t%ends(1, e)) + xc(t%ends(2, e)))
    end do
  end subroutine prolong_add

  !> x = x + alpha w with the projected direction w = max(x + v, bnd) - x on the bounded
  !> unknowns (v elsewhere; v is zero at the frozen ones) and alpha minimising the energy
  !> J(x + alpha w) = J(x) - alpha r.w + alpha^2/2 w.Aw over the feasible alphas [0, alpha_max]
  !> (alpha_max >= 1).  On return v holds w.  v = P_T v_c on entry (coarse_correction, v_c
  !> the solution on grid L-1, A_c = P_T^T A P_T its operator), so with d = w - v (non-zero
  !> only where the projection clips) w.Aw = v_c.A_c v_c + d.A(v + w): a product on grid
  !> L-1 and the rows of the clipped unknowns instead of a product with A
  !> (line_search_curvature).
  subroutine line_search(h, a, kind, bnd, r, v, x)
    type(mg_hierarchy_t), intent(in) :: h
    type(csr_t), intent(in) :: a
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:), r(:)
    real(dp), intent(inout) :: v(:)
    real(dp), intent(inout) :: x(:)
    real(dp) :: alpha, alpha_max, waw, rw
    integer :: i
    call line_search_curvature(h, a, kind, bnd, x, v, waw)   ! (v becomes w)
    rw = 0.0_dp
    alpha_max = huge(1.0_dp)
    do i = 1, a%n
      if (kind(i) == BOUND_LOWER .and. v(i) < 0.0_dp) alpha_max = min(alpha_max, (x(i) - bnd(i)) / (-v(i)))
      rw = rw + r(i) * v(i)
    end do
    if (.not. (waw > 0.0_dp) .or. .not. (rw > 0.0_dp)) return
    alpha = min(rw / waw, alpha_max)
    do i = 1, a%n
      x(i) = x(i) + alpha * v(i)
      if (kind(i) == BOUND_LOWER) x(i) = max(x(i), bnd(i))
    end do
  end subroutine line_search

  !> v <- w = max(x + v, bnd) - x on the bounded unknowns, and waw = w.Aw, for line_search.
  !> When the projection clips at most a fraction line_search_clip_max of the unknowns,
  !> waw = v_c.A_c v_c + sum over the clipped i of d_i ((A v)_i + (A w)_i), d = w - v;
  !> otherwise by a product with A.
  subroutine line_search_curvature(h, a, kind, bnd, x, v, waw)
    type(mg_hierarchy_t), intent(in) :: h
    type(csr_t), intent(in) :: a
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:), x(:)
    real(dp), intent(inout) :: v(:)
    real(dp), intent(out) :: waw
    integer, allocatable :: clip(:)
    real(dp), allocatable :: av(:), dv(:)
    integer :: i, k, m, ierr
    m = 0
    do i = 1, a%n
      if (kind(i) == BOUND_LOWER) then
        if (x(i) + v(i) < bnd(i)) m = m + 1
      end if
    end do
    ierr = 1
    if (real(m, dp) <= line_search_clip_max * real(a%n, dp)) allocate (clip(m), av(m), dv(m), stat=ierr)
    if (ierr /= 0) then                          ! many clipped (or no memory): w.Aw directly
      where (kind == BOUND_LOWER) v = max(x + v, bnd) - x
      waw = quadratic_form(a, v)
      return
    end if
    k = 0
    do i = 1, a%n
      if (kind(i) == BOUND_LOWER) then
        if (x(i) + v(i) < bnd(i)) then
          k = k + 1
          clip(k) = i
          av(k) = row_dot(a, i, v)                 ! (A v)_i before the clipping
        end if
      end if
    end do
    do k = 1, m
      i = clip(k)
      dv(k) = (bnd(i) - x(i)) - v(i)
      v(i) = bnd(i) - x(i)
    end do
    associate (g => h%grid(h%nlevel - 1))
      waw = quadratic_form(g%a, g%x)
    end associate
    do k = 1, m
      waw = waw + dv(k) * (av(k) + row_dot(a, clip(k), v))
    end do
  end subroutine line_search_curvature

  !> y^T A y without storing A y.
  pure real(dp) function quadratic_form(a, y) result(q)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: y(:)
    integer :: i
    q = 0.0_dp
    do i = 1, a%n
      q = q + y(i) * row_dot(a, i, y)
    end do
  end function quadratic_form

  !> (A y)_i.
  pure real(dp) function row_dot(a, i, y) result(s)
    type(csr_t), intent(in) :: a
    integer, intent(in) :: i
    real(dp), intent(in) :: y(:)
    integer :: p
    s = 0.0_dp
    do p = a%rowptr(i), a%rowptr(i + 1) - 1
      s = s + a%val(p) * y(a%col(p))
    end do
  end function row_dot

  !> One projected Gauss-Seidel sweep, in increasing (forward) or decreasing order:
  !> x_i <- max(x_i + (F_i - (A x)_i) / A_ii, bnd_i) for the bounded unknowns, without the
  !> max for the free ones; fixed unknowns are not touched.
  pure subroutine sweep_projected(a, f, kind, bnd, x, forward)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    logical, intent(in) :: forward
    integer :: i, p, i0, i1, di
    real(dp) :: r, y
    i0 = merge(1, a%n, forward)
    i1 = merge(a%n, 1, forward)
    di = merge(1, -1, forward)
    do i = i0, i1, di
      if (kind(i) == BOUND_FIXED) cycle
      r = f(i)
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        r = r - a%val(p) * x(a%col(p))
      end do
      y = x(i) + r / a%val(a%diag(i))
      if (kind(i) == BOUND_LOWER) y = max(y, bnd(i))
      x(i) = y
    end do
  end subroutine sweep_projected

  !> Bytes held by the hierarchy h (prolongations, coarse operators and vectors) plus the
  !> work arrays of a solve with n unknowns (two real vectors, two logical masks).
  pure integer(i8) function mg_memory_bytes(h, n) result(bytes)
    type(mg_hierarchy_t), intent(in) :: h
    integer, intent(in) :: n
    integer :: l
    bytes = int(n, i8) * (2 * 8 + 2 * 4)
    do l = 2, h%nlevel
      associate (t => h%transfer(l))
        if (allocated(t%ends)) bytes = bytes + 4_i8 * (size(t%ends, kind=i8) + size(t%cptr, kind=i8) + &
                                                       size(t%child, kind=i8))
        if (allocated(t%p%val)) bytes = bytes + 24_i8 * size(t%p%val, kind=i8) + 4_i8 * (2 * t%nf + t%nc + 2)
      end associate
    end do
    if (.not. allocated(h%grid)) return
    do l = 1, size(h%grid)
      associate (g => h%grid(l))
        if (allocated(g%a%val)) bytes = bytes + 12_i8 * size(g%a%val, kind=i8) + 8_i8 * (g%a%n + 1)
        if (allocated(g%x)) bytes = bytes + 24_i8 * size(g%x, kind=i8)
      end associate
    end do
  end function mg_memory_bytes
end module dualsig_solver_multigrid
