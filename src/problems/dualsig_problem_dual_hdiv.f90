!> The dual problem of P1 (Section 3) in the H(div)-conforming space RT1: q_h minimises
!> I(q) of (3.1') over U_0h = {q in RT1 : q.nu >= 0 on Gamma}, a subset of the paper's
!> U_0 = {q in Q : q.nu|_Gamma >= 0} (RT1 is a subspace of Q = H(div)), so every bound of
!> Section 6 holds with it.  lambda^h = [q_h, f + div q_h] is in U_1 (Remark 3.1).
!>
!> Why this space: with continuous P1 vector fields (the paper's [V_h]^2) div q is piecewise
!> constant and ||f + div q - u~|| = O(h) with a large constant dominates E of (6.13); in RT1
!> div q is piecewise linear, q and f + div q converge as O(h^2) (the mixed method of order
!> 1), so E(q_h, u~_h) = ||u - u~_h||_1^2 (1 + O(h^2)) + (complementarity terms).
!>
!> Constraints: on a boundary edge the normal trace of RT1 is linear, so q.nu >= 0 on the
!> edge holds exactly when it holds at both ends; the unknowns of a boundary edge are these
!> two end values (dualsig_assembly_dual_hdiv), so U_0h is given by simple bounds
!> x_i >= 0, one pair per boundary edge (corners need nothing special: each edge has its own
!> pair).  With the interior unknowns condensed the problem is
!>     minimise 1/2 x^T S x - c^T x,  x_i >= 0 on boundary edges,   S SPD,
!> solved by
!> - 'active_set' (default): the primal-dual active-set method, one CHOLMOD factorisation
!>   (changes of the active set bordered on it), started from the complementarity prediction
!>   of the primal solution: where u_h > 0 at a boundary node, q.nu = 0 there (held), where
!>   u_h = 0, q.nu free; the other unknowns start from the normal component of grad u_h;
!> - 'uzawa': the paper's algorithm with B = the selection of the bounded unknowns, S
!>   factorised once; its last iterate is projected on the bounds (feasible);
!> - 'nested' (with the state `nest` carried over uniformly refined levels): on the first
!>   level 'active_set'; on every later level an INEXACT solve without factorisation,
!>   started from the previous level's field prolongated exactly (hdiv_prolongate).  The
!>   bounded unknowns are held at 0 where the complementarity prediction says so (and where
!>   the start is 0 without u_primal), the others improved by CG preconditioned by a
!>   V-cycle over all levels (dualsig_patch_schwarz: Arnold-Falk-Winther vertex patches,
!>   forward multiplicative sweeps, the first level factorised; flexible CG), stopped when
!>   a step gains less than nested_rel_decrease of the current est (computable: est =
!>   2 (J - j_floor), see nested_floor); free bounded unknowns that went negative are then
!>   set to 0 and held and the boundary patches relaxed once (J does not increase; at most
!>   nested_max_rounds times).  Any feasible field gives guaranteed bounds, so only their
!>   sharpness depends on how far the iteration went.  The last level of a uniform run
!>   (nest%last) joins no hierarchy: matrix-free projected patch sweeps from the prolongated
!>   field (solve_smoothed, dualsig_dual_hdiv_smoother), with the nested solve as fallback.
module dualsig_problem_dual_hdiv
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t, mesh_move
  use dualsig_sparse, only: rect_t, rect_from_triplets, csr_t, csr_quadratic_change
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_ordering_geometric, only: select_ordering
  use dualsig_spd_solver, only: cholmod_spd_t
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, ROW_INEQUALITY
  use dualsig_solver_uzawa, only: uzawa_settings_t, uzawa_result_t, uzawa_solve
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_elements_p1, only: p1_gradients
  use dualsig_assembly_dual_hdiv, only: hdiv_system_t, assemble_dual_hdiv, hdiv_recover, hdiv_dof_points, &
                                        hdiv_prolongate, hdiv_nfield, hdiv_bedge_dofs, hdiv_prolongate_interior, &
                                        hdiv_prolongation_matrix
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_result_from_active_set
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT
  use dualsig_patch_schwarz, only: mg_hierarchy_t, mg_add_level, mg_free, mg_hold, pcg_quadratic, pcg_result_t, mg_relax_bounded
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  use dualsig_load_data, only: load_data_t
  use dualsig_dual_hdiv_smoother, only: hdiv_local_t, hdiv_local_build, hdiv_local_sweep, &
                                        hdiv_local_recover
  implicit none
  private

  public :: dual_hdiv_solve, dual_hdiv_bound_kinds, dual_hdiv_start
  public :: hdiv_nested_t, dual_hdiv_nested_refine, dual_hdiv_nested_free

  !> The state of method 'nested' between uniformly refined levels.
  type :: hdiv_nested_t
    type(mg_hierarchy_t) :: mg               !! the levels solved so far (matrices, prolongations)
    real(dp), allocatable :: q(:)            !! the last level's field; after a refinement its prolongation
    real(dp), allocatable :: rec_k(:,:,:)    !! the last level's condensation (hdiv_system_t%rec_k)
    type(rect_t) :: p_next                   !! after a refinement: the prolongation of side unknowns
    logical :: ready = .false.               !! q and p_next belong to the current mesh
    !> the last measured ratio of consecutive CG decreases (pcg_result_t%step_ratio; 0: none)
    real(dp) :: cg_ratio = 0.0_dp
    !> the numbering of the last level in the hierarchy: its side unknown i (field vector)
    !> is unknown perm(i) of its matrix (patch_numbering); not allocated: the identity
    integer, allocatable :: perm(:)
    !> after a refinement: the vertex patches of the new mesh (vertex_patches, in the field's
    !> numbering) and the numbering of its matrix (patch_numbering), in which p_next's rows
    !> already are
    integer, allocatable :: ptr_next(:), idx_next(:), perm_next(:)
    !> after a refinement for the last level of a uniform run (dual_hdiv_nested_refine's
    !> last): the level is solved by the matrix-free sweeps (solve_smoothed) from q
    !> prolongated from `coarse` (kept for that and for the fallback to the nested solve),
    !> not added to the hierarchy
    logical :: last = .false.
    type(mesh_t) :: coarse
  end type hdiv_nested_t

  !> Start value of a bounded unknown predicted free (contact: q.nu > 0 expected).
  real(dp), parameter :: free_start = 1.0_dp
  !> 'nested': stop when a CG step decreases est by less than this fraction of est.
  real(dp), parameter :: nested_rel_decrease = 1.0e-3_dp
  !> 'nested': CG steps at most, and rounds of holding negative bounded unknowns (each with
  !> a relaxation of the boundary patches).
  integer, parameter :: nested_max_iter = 500, nested_max_rounds = 4
  !> 'nested': CG again after a round of setting negative bounded unknowns to 0 where that
  !> left J - j_floor above this multiple of its value after the CG.
  real(dp), parameter :: repair_factor = 2.0_dp
  !> The last level of a uniform run ('nested', nest%last): projected patch sweeps at most
  !> (the stop is settings%algebraic_share's, solve_smoothed).
  integer, parameter :: smooth_max_sweeps = 8

contains

  !> Solve the RT1 dual problem on `mesh` and return the FEASIBLE field x (hdiv_nfield:
  !> side unknowns, then interior ones): q.nu >= 0 at both ends of every boundary edge.
  !> f is integrated with `rule` in the load vector, or enters through its load data `load`
  !> (optional: exact, see assemble_dual_hdiv).  u_primal (optional, nnode): the primal
  !> solution, for the first active set (complementarity) and the start.  st carries
  !> DS_WARN_NOT_CONVERGED when the iteration limit was reached (x is still feasible).
  !> sys_out (optional) returns the condensed system (for tests; on the levels of 'nested'
  !> after the first, in the numbering of nest%perm).
  subroutine dual_hdiv_solve(mesh, f, rule, settings, x, res, st, u_primal, sys_out, nest, load)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(dual_p1_settings_t), intent(in) :: settings
    real(dp), allocatable, intent(out) :: x(:)
    type(dual_p1_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: u_primal(:)
    type(hdiv_system_t), intent(out), optional :: sys_out
    type(hdiv_nested_t), intent(inout), optional :: nest   !! 'nested': the state between levels
    type(load_data_t), intent(in), optional :: load        !! the load data of f: f enters through it
    type(hdiv_system_t) :: sys
    integer, allocatable :: kind(:), ptr(:), idx(:), perm(:)
    real(dp), allocatable :: xs(:)
    integer :: n, ist
    logical :: nested, inexact, smoothed

    if (all(trim(settings%method) /= [character(len=10) :: 'active_set', 'uzawa', 'nested'])) then
      call set_error(st, DS_ERR_INPUT, 'dual P1 (hdiv): unknown method "' // trim(settings%method) // &
        '"; expected active_set, uzawa or nested')
      return
    end if
    nested = trim(settings%method) == 'nested' .and. present(nest)
    inexact = .false.
    smoothed = .false.
    if (nested) inexact = nest%ready
    if (inexact) smoothed = nest%last
    if (smoothed) then
      ! the last level of a uniform run: matrix-free sweeps from the prolongated field; where
      ! they do not reach the share of est asked for (a domain so small that the divergence
      ! term dominates, whose smooth part needs the coarse correction), the nested solve
      ! from the prolongated field (res then reports the nested solve)
      call solve_smoothed(mesh, f, rule, settings, nest, x, res, st, u_primal, load)
      if (.not. is_ok(st)) return
      if (res%converged) then
        if (present(sys_out)) call assemble_dual_hdiv(mesh, f, rule, sys_out, st, u_primal, load)
        return
      end if
      call nested_fallback(nest, mesh, st)
      if (.not. is_ok(st)) return
      deallocate (x)
      res = dual_p1_result_t()
    end if
    if (inexact) then
      ! the vertex patches of the V-cycle's smoother, and the level's unknowns numbered as
      ! the patches first reach them, so that a patch's rows lie together in memory (made
      ! by dual_hdiv_nested_refine, the prolongation's rows in this numbering)
      call move_alloc(nest%ptr_next, ptr)
      call move_alloc(nest%idx_next, idx)
      call move_alloc(nest%perm_next, perm)
      call assemble_dual_hdiv(mesh, f, rule, sys, st, u_primal, load, renumber=perm)
    else
      call assemble_dual_hdiv(mesh, f, rule, sys, st, u_primal, load)
    end if
    if (.not. is_ok(st)) return
    n = sys%a%n
    call dual_hdiv_bound_kinds(mesh, kind, st)
    if (.not. is_ok(st)) return
    res%nconstraints = count(kind == BOUND_LOWER)
    allocate (xs(n), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 dual vectors', n, BYTES_REAL)) return
    xs = 0.0_dp
    if (trim(settings%method) == 'uzawa') then
      call solve_uzawa(mesh, sys, kind, settings, xs, res, st)
    else if (inexact) then
      xs = nest%q(1:n)
      call solve_nested(mesh, sys, kind, settings, nest, ptr, idx, perm, xs, res, st, u_primal)
    else
      ! 'active_set', and the first level of 'nested' (the coarsest level of its hierarchy)
      if (nested) call dual_hdiv_nested_free(nest)
      call solve_active_set(mesh, sys, kind, settings, xs, res, st, u_primal)
    end if
    if (.not. is_ok(st)) return
    ! feasible by construction (active set) or by projection (Uzawa)
    where (kind == BOUND_LOWER) xs = max(xs, 0.0_dp)
    res%nactive = count(kind == BOUND_LOWER .and. xs <= 0.0_dp)
    allocate (x(hdiv_nfield(mesh)), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 dual field', hdiv_nfield(mesh), BYTES_REAL)) return
    call hdiv_recover(mesh, sys, xs, x)
    if (present(sys_out)) sys_out = sys
    if (nested) then
      ! the level's condensation is the hierarchy's now (hdiv_prolongation_matrix needs it);
      ! an exactly solved first level becomes the hierarchy's coarsest level
      nest%q = x
      call move_alloc(sys%rec_k, nest%rec_k)
      if (.not. inexact) call mg_add_level(nest%mg, sys%a, nest%p_next, [1], [integer ::], kind == BOUND_LOWER, st)
    end if
  end subroutine dual_hdiv_solve

  !> The exact solve of method 'active_set': the primal-dual active-set method on the
  !> condensed system, one CHOLMOD factorisation in the ordering of settings, started from
  !> u_primal when given (dual_hdiv_start).
  subroutine solve_active_set(mesh, sys, kind, settings, xs, res, st, u_primal)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_system_t), intent(in) :: sys
    integer, intent(in) :: kind(:)
    type(dual_p1_settings_t), intent(in) :: settings
    real(dp), intent(inout) :: xs(:)
    type(dual_p1_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: u_primal(:)
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    real(dp), allocatable :: zero(:), pts(:,:)
    integer :: n, ist
    n = size(xs)
    allocate (zero(n), pts(2, n), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 dual vectors', 3 * n, BYTES_REAL)) return
    zero = 0.0_dp
    call hdiv_dof_points(mesh, pts)
    if (present(u_primal)) call dual_hdiv_start(mesh, u_primal, xs)
    aset%max_iter = settings%max_iter
    call select_ordering(settings%ordering, pts, sys%a, aset%ordering, aset%perm, st)
    if (.not. is_ok(st)) return
    call active_set_solve(sys%a, sys%b, kind, zero, xs, aset, ares, st)
    call dual_p1_result_from_active_set(ares, res)
  end subroutine solve_active_set

  !> Bound kinds of the side unknowns: BOUND_LOWER (>= 0) on boundary edges, free otherwise.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_hdiv_bound_kinds(mesh, kind, st)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable, intent(out) :: kind(:)
    type(status_t), intent(inout) :: st
    integer :: j, dofs(2), ist
    allocate (kind(2 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the bound kinds of the RT1 unknowns', 2 * mesh%nedge, BYTES_INT)) return
    kind = BOUND_FREE
    do j = 1, mesh%nbedge
      call hdiv_bedge_dofs(mesh, j, dofs)
      kind(dofs) = BOUND_LOWER
    end do
  end subroutine dual_hdiv_bound_kinds

  !> Start of the active-set solver from the primal solution u (nnode): on interior edges
  !> the mean normal component of grad u_h of the two triangles; on boundary edges 0 where
  !> u > 0 at the node (complementarity: q.nu = 0 predicted, held) and free_start where
  !> u = 0 (contact: predicted free).
  subroutine dual_hdiv_start(mesh, u, xs)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    real(dp), intent(out) :: xs(:)
    real(dp) :: grad(2, 3), area, gu(2), d(2), nu(2)
    integer :: t, k, e, j, dofs(2), side
    xs = 0.0_dp
    do t = 1, mesh%ntri
      call p1_gradients(mesh%xy(:, mesh%tri(:, t)), grad, area)
      gu = matmul(grad, u(mesh%tri(:, t)))
      do k = 1, 3
        e = mesh%tri_edge(k, t)
        if (mesh%edge_tri(2, e) == 0) cycle
        ! outward normal of t on its side a_k a_{k+1} (counter-clockwise); nu_e = +-nu
        d = mesh%xy(:, mesh%tri(mod(k, 3) + 1, t)) - mesh%xy(:, mesh%tri(k, t))
        nu = [d(2), -d(1)] / hypot(d(1), d(2))
        if (mesh%edge_tri(1, e) /= t) nu = -nu
        xs(2 * e - 1:2 * e) = xs(2 * e - 1:2 * e) + 0.5_dp * dot_product(gu, nu)
      end do
    end do
    do j = 1, mesh%nbedge
      call hdiv_bedge_dofs(mesh, j, dofs)
      do side = 1, 2
        xs(dofs(side)) = merge(0.0_dp, free_start, u(mesh%bedge_nodes(side, j)) > 0.0_dp)
      end do
    end do
  end subroutine dual_hdiv_start

  !> The state of 'nested' after the uniform refinement of coarse into fine: the last
  !> field prolongated (the start) and the prolongation of side unknowns (the V-cycle's).
  !> Out of memory: DS_ERR_MEMORY in st.
  subroutine dual_hdiv_nested_refine(nest, coarse, fine, st, last)
    type(hdiv_nested_t), intent(inout) :: nest
    type(mesh_t), intent(in) :: coarse, fine
    type(status_t), intent(inout) :: st
    !> fine is the last level of the run: only the field is prolongated (solve_smoothed)
    logical, intent(in), optional :: last
    real(dp), allocatable :: q_next(:)
    integer :: ist
    nest%last = .false.
    if (present(last)) nest%last = last
    if (nest%last) then
      nest%coarse = coarse
      nest%ready = .true.
      return
    end if
    allocate (q_next(hdiv_nfield(fine)), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated RT1 field', hdiv_nfield(fine), BYTES_REAL)) return
    ! the fine level's patches and numbering first, so that the prolongation is built in
    ! the numbering of the level matrices (rows: the fine one, columns: nest%perm)
    call vertex_patches(fine, nest%ptr_next, nest%idx_next, st)
    if (.not. is_ok(st)) return
    call patch_numbering(2 * fine%nedge, nest%idx_next, nest%perm_next, st)
    if (.not. is_ok(st)) return
    ! (nest%perm not allocated, after an exact first level: col_perm is absent, the identity)
    call hdiv_prolongation_matrix(coarse, fine, nest%rec_k, nest%p_next, st, nest%q, q_next, &
                                  row_perm=nest%perm_next, col_perm=nest%perm)
    if (.not. is_ok(st)) return
    call hdiv_prolongate_interior(coarse, fine, nest%q, q_next)
    call move_alloc(q_next, nest%q)
    nest%ready = .true.
  end subroutine dual_hdiv_nested_refine

  !> Release the state of 'nested' (the next solve starts a new hierarchy).
  subroutine dual_hdiv_nested_free(nest)
    type(hdiv_nested_t), intent(inout) :: nest
    call mg_free(nest%mg)
    nest = hdiv_nested_t()
  end subroutine dual_hdiv_nested_free

  !> Method 'nested' on the last level of a uniform run (nest%last): from the previous
  !> level's field prolongated (exact, feasible), projected multiplicative sweeps over the
  !> vertex patches without an assembled matrix (dualsig_dual_hdiv_smoother).  No coarse
  !> correction: what the previous level left stays, a small part of est because the RT1
  !> field's error is of higher order than the primal's (theory.md).  The field is feasible
  !> after every patch step and J never increases, so the bounds are guaranteed whenever
  !> the sweeps stop.  They stop when the part of est that further sweeps could remove
  !> (twice the decrease of J, predicted from the last two sweeps' decreases as a geometric
  !> series; after one sweep: what it removed) is at most settings%algebraic_est_tol, or,
  !> where that is 0, settings%algebraic_share of the sweeps' own est = 2 (J - j_floor); or
  !> after smooth_max_sweeps (res%converged .false.: dual_hdiv_solve falls back to the
  !> nested solve).  The level joins no hierarchy (nest%ready is .false. on return).
  subroutine solve_smoothed(mesh, f, rule, settings, nest, x, res, st, u_primal, load)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(dual_p1_settings_t), intent(in) :: settings
    type(hdiv_nested_t), intent(inout) :: nest
    real(dp), allocatable, intent(out) :: x(:)
    type(dual_p1_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: u_primal(:)
    type(load_data_t), intent(in), optional :: load
    type(hdiv_local_t) :: loc
    integer, allocatable :: kind(:), order(:)
    logical, allocatable :: bounded(:)
    real(dp), allocatable :: xs(:)
    real(dp) :: j_floor, j_now, dj, dj_prev, left
    integer :: n, k, ist
    nest%ready = .false.
    call dual_hdiv_bound_kinds(mesh, kind, st)
    if (.not. is_ok(st)) return
    call z_order(mesh, order, st)
    if (.not. is_ok(st)) return
    n = 2 * mesh%nedge
    allocate (xs(n), bounded(n), x(hdiv_nfield(mesh)), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 dual vectors', n + hdiv_nfield(mesh), BYTES_REAL)) return
    ! the start: the previous level's field (exact, and feasible up to rounding); its side
    ! unknowns only (the interior ones are recovered from the swept side unknowns)
    call hdiv_prolongate(nest%coarse, mesh, nest%q, x, sides_only=.true.)
    where (kind == BOUND_LOWER) x(1:n) = max(x(1:n), 0.0_dp)
    call hdiv_local_build(mesh, f, rule, order, loc, st, u_primal, load, x0=x(1:n), j0=j_now, xp0=xs)
    if (.not. is_ok(st)) return
    bounded(loc%perm) = kind == BOUND_LOWER
    res%nconstraints = count(bounded)
    j_floor = nested_floor_of(loc%shift, loc%data_sq, loc%data_osc_sq)
    dj = 0.0_dp
    left = huge(1.0_dp)
    do k = 1, smooth_max_sweeps
      dj_prev = dj
      call hdiv_local_sweep(loc, bounded, xs, dj, st)
      if (.not. is_ok(st)) return
      j_now = j_now - dj
      res%iterations = k
      ! what further sweeps could remove: dj q / (1 - q), q the last ratio of decreases
      ! (after the first sweep, or when a sweep gained nothing: dj itself)
      if (k == 1 .or. .not. dj > 0.0_dp) then
        left = dj
      else if (dj < dj_prev) then
        left = dj * dj / (dj_prev - dj)
      else
        left = huge(1.0_dp)                 ! no contraction measured
      end if
      if (settings%algebraic_est_tol > 0.0_dp) then
        res%converged = left <= 0.5_dp * settings%algebraic_est_tol
      else
        res%converged = left <= settings%algebraic_share * max(j_now - j_floor, 0.0_dp)
      end if
      if (res%converged) exit
    end do
    res%residual = min(left, dj) / max(j_now - j_floor, tiny(1.0_dp))
    res%nactive = count(bounded .and. xs <= 0.0_dp)
    call hdiv_local_recover(loc, xs, x)
  end subroutine solve_smoothed

  !> The fallback of the last level (nest%last) to the nested solve: the refinement of
  !> nest%coarse into mesh made as for any level (patches, numbering, prolongation matrix,
  !> the prolongated start; dual_hdiv_nested_refine).  The swept field is not the start: on
  !> the domains where the sweeps stall, the nested solve's complementarity prediction and
  !> repair rounds are tuned from the prolongated field (the swept one left eff 68 at level 3
  !> of side 1e-4, against 1.011).
  subroutine nested_fallback(nest, mesh, st)
    type(hdiv_nested_t), intent(inout) :: nest
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(inout) :: st
    type(mesh_t) :: coarse
    call mesh_move(nest%coarse, coarse)
    nest%last = .false.
    call dual_hdiv_nested_refine(nest, coarse, mesh, st)
  end subroutine nested_fallback

  !> The inexact solve of method 'nested' from the start xs (see the module header); the
  !> level joins the hierarchy of nest.  sys is assembled in the numbering perm
  !> (patch_numbering of the vertex patches ptr/idx, which are in the field's numbering);
  !> xs and kind are in the field's numbering, on entry and on return.
  subroutine solve_nested(mesh, sys, kind, settings, nest, ptr, idx, perm, xs, res, st, u_primal)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_system_t), intent(inout) :: sys
    integer, intent(in) :: kind(:)
    type(dual_p1_settings_t), intent(in) :: settings
    type(hdiv_nested_t), intent(inout) :: nest
    integer, intent(in) :: ptr(:)
    integer, intent(inout) :: idx(:)
    integer, allocatable, intent(inout) :: perm(:)
    real(dp), intent(inout) :: xs(:)
    type(dual_p1_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: u_primal(:)
    logical, allocatable :: free(:), bounded(:)
    real(dp), allocatable :: xp(:)
    integer :: ist
    where (kind == BOUND_LOWER) xs = max(xs, 0.0_dp)
    allocate (free(size(xs)), bounded(size(xs)), xp(size(xs)), stat=ist)
    if (alloc_failed(ist, st, 'the nested RT1 vectors', 2 * size(xs), BYTES_REAL)) return
    free = .not. (kind == BOUND_LOWER .and. xs <= 0.0_dp)
    if (present(u_primal)) call complementarity_prediction(mesh, u_primal, xs, free)
    ! to the level's numbering: the start, the masks, the patches (the prolongation is in it)
    xp(perm) = xs
    free(perm) = free
    bounded(perm) = kind == BOUND_LOWER
    idx = perm(idx)
    call mg_add_level(nest%mg, sys%a, nest%p_next, ptr, idx, bounded, st)
    if (.not. is_ok(st)) return
    nest%ready = .false.
    call nested_iterate(sys, bounded, nest, settings, free, xp, res, st)
    if (.not. is_ok(st)) return
    xs = xp(perm)
    call move_alloc(perm, nest%perm)
  end subroutine solve_nested

  !> The iteration of 'nested' on the level just added to nest%mg (its numbering): CG from
  !> x on the free unknowns, then rounds of holding the free bounded unknowns that went
  !> negative (module header).  x is feasible on return and never worse than on entry.
  subroutine nested_iterate(sys, bounded, nest, settings, free, x, res, st)
    type(hdiv_system_t), intent(in) :: sys
    logical, intent(in) :: bounded(:)
    type(hdiv_nested_t), intent(inout) :: nest
    type(dual_p1_settings_t), intent(in) :: settings
    logical, intent(inout) :: free(:)
    real(dp), intent(inout) :: x(:)
    type(dual_p1_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    type(pcg_result_t) :: pres
    real(dp), allocatable :: x0(:), x_prev(:)
    real(dp) :: j_floor, j_now, j_start
    integer :: round, ist
    allocate (x0(size(x)), x_prev(size(x)), stat=ist)
    if (alloc_failed(ist, st, 'the nested RT1 vectors', 2 * size(x), BYTES_REAL)) return
    x0 = x
    j_floor = nested_floor(sys)
    call mg_hold(nest%mg, free, st)
    if (.not. is_ok(st)) return
    call pcg_quadratic(nest%mg, sys%b, free, j_floor, nested_rel_decrease, &
                       min(settings%max_iter, nested_max_iter), x, pres, st, ratio=nest%cg_ratio)
    if (.not. is_ok(st)) return
    if (pres%step_ratio > 0.0_dp) nest%cg_ratio = pres%step_ratio
    res%iterations = pres%iterations
    res%converged = pres%converged
    res%residual = pres%last_decrease / max(pres%j_value - j_floor, tiny(1.0_dp))
    ! free bounded unknowns that went negative: held at 0, the patches at the boundary
    ! relaxed (J does not increase: a local repair of the setting to 0); where the setting
    ! to 0 cost more than repair_factor times what the CG had left (J - j_floor), which one
    ! relaxation does not recover (P1 on a domain of diameter 1e-4, where the divergence
    ! term dominates S by 1e10), CG again with the new hold.  J is followed by its changes
    ! (csr_quadratic_change: only the rows of the unknowns that changed), not recomputed.
    j_now = pres%j_value
    x_prev = x
    do round = 1, nested_max_rounds
      if (.not. any(free .and. bounded .and. x < 0.0_dp)) exit
      where (free .and. bounded .and. x < 0.0_dp)
        x = 0.0_dp
        free = .false.
      end where
      call mg_hold(nest%mg, free, st)
      if (.not. is_ok(st)) return
      call mg_relax_bounded(nest%mg, sys%b, x, 1)
      j_now = j_now + csr_quadratic_change(nest%mg%lev(nest%mg%nlevel)%a, sys%b, x_prev, x)
      if (j_now - j_floor > repair_factor * max(pres%j_value - j_floor, 0.0_dp)) then
        j_start = pres%j_start
        call pcg_quadratic(nest%mg, sys%b, free, j_floor, nested_rel_decrease, &
                           min(settings%max_iter, nested_max_iter), x, pres, st, ratio=nest%cg_ratio)
        if (.not. is_ok(st)) return
        pres%j_start = j_start
        j_now = pres%j_value
        res%iterations = res%iterations + pres%iterations
        res%converged = pres%converged
        res%residual = pres%last_decrease / max(pres%j_value - j_floor, tiny(1.0_dp))
      end if
      x_prev = x
    end do
    ! feasible; never worse than the start (feasible too)
    where (bounded) x = max(x, 0.0_dp)
    j_now = j_now + csr_quadratic_change(nest%mg%lev(nest%mg%nlevel)%a, sys%b, x_prev, x)
    if (j_now > pres%j_start) x = x0
  end subroutine nested_iterate

  !> The numbering of the side unknowns (n of them) in which the vertex patches idx (in the
  !> field's numbering, in their order along the Z-order curve) first reach them:
  !> unknown i becomes perm(i).  Every side unknown is in a patch (an edge has two ends).
  subroutine patch_numbering(n, idx, perm, st)
    integer, intent(in) :: n
    integer, intent(in) :: idx(:)
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(inout) :: st
    integer :: k, next, ist
    allocate (perm(n), source=0, stat=ist)
    if (alloc_failed(ist, st, 'the numbering of the RT1 unknowns', n, BYTES_INT)) return
    next = 0
    do k = 1, size(idx)
      if (perm(idx(k)) /= 0) cycle
      next = next + 1
      perm(idx(k)) = next
    end do
    do k = 1, n                      ! none left on a mesh; kept a permutation regardless
      if (perm(k) /= 0) cycle
      next = next + 1
      perm(k) = next
    end do
  end subroutine patch_numbering

  !> The active set predicted by complementarity with the primal solution u (nnode), as
  !> for the active-set start: a bounded unknown at a node with u > 0 is held at 0
  !> (q.nu = 0 predicted), one at a node with u = 0 is free.
  subroutine complementarity_prediction(mesh, u, xs, free)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    real(dp), intent(inout) :: xs(:)
    logical, intent(inout) :: free(:)
    integer :: j, side, dofs(2)
    do j = 1, mesh%nbedge
      call hdiv_bedge_dofs(mesh, j, dofs)
      do side = 1, 2
        free(dofs(side)) = .not. u(mesh%bedge_nodes(side, j)) > 0.0_dp
        if (.not. free(dofs(side))) xs(dofs(side)) = 0.0_dp
      end do
    end do
  end subroutine complementarity_prediction

  !> The vertex patches of the side unknowns: for every node, the unknowns of the edges at
  !> it (both ends of each edge); the patches in the order of the nodes along a Z-order
  !> (Morton) curve, so that consecutive patches share unknowns and matrix rows (cache
  !> locality of the sweeps).
  subroutine vertex_patches(mesh, ptr, idx, st)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable, intent(out) :: ptr(:), idx(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: fill(:), order(:), rank(:)
    integer :: e, j, v, i, ist, p
    call z_order(mesh, order, st)
    if (.not. is_ok(st)) return
    allocate (rank(mesh%nnode), ptr(mesh%nnode + 1), stat=ist)
    if (alloc_failed(ist, st, 'the vertex patches', 2 * mesh%nnode + 1, BYTES_INT)) return
    do p = 1, mesh%nnode
      rank(order(p)) = p
    end do
    ptr = 0
    do e = 1, mesh%nedge
      do j = 1, 2
        p = rank(mesh%edge_nodes(j, e))
        ptr(p + 1) = ptr(p + 1) + 2
      end do
    end do
    ptr(1) = 1
    do v = 1, mesh%nnode
      ptr(v + 1) = ptr(v + 1) + ptr(v)
    end do
    allocate (idx(ptr(mesh%nnode + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the vertex patches', ptr(mesh%nnode + 1) - 1, BYTES_INT)) return
    fill = ptr(1:mesh%nnode)
    do e = 1, mesh%nedge
      do j = 1, 2
        p = rank(mesh%edge_nodes(j, e))
        do i = 2 * e - 1, 2 * e
          idx(fill(p)) = i
          fill(p) = fill(p) + 1
        end do
      end do
    end do
  end subroutine vertex_patches

  !> The nodes of mesh along a Z-order curve: sorted by the Morton index of their cell in a
  !> 2^k x 2^k grid over the bounding box (about 4 nodes per cell; counting sort).
  subroutine z_order(mesh, order, st)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable, intent(out) :: order(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: key(:), start(:)
    real(dp) :: lo(2), span(2)
    integer :: k, ncell, v, ix, iy, b, m, ist
    k = 1
    do while (4**(k + 1) <= max(1, mesh%nnode / 4) .and. k < 14)
      k = k + 1
    end do
    ncell = 4**k
    allocate (key(mesh%nnode), start(ncell + 1), order(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the node order of the vertex patches', 2 * mesh%nnode + ncell + 1, BYTES_INT)) return
    lo = minval(mesh%xy, dim=2)
    span = max(maxval(mesh%xy, dim=2) - lo, tiny(1.0_dp))
    start = 0
    do v = 1, mesh%nnode
      ix = min(int((mesh%xy(1, v) - lo(1)) / span(1) * 2**k), 2**k - 1)
      iy = min(int((mesh%xy(2, v) - lo(2)) / span(2) * 2**k), 2**k - 1)
      m = 0
      do b = 0, k - 1
        m = ior(m, ishft(iand(ishft(ix, -b), 1), 2 * b))
        m = ior(m, ishft(iand(ishft(iy, -b), 1), 2 * b + 1))
      end do
      key(v) = m + 1
      start(m + 2) = start(m + 2) + 1
    end do
    start(1) = 1
    do m = 1, ncell
      start(m + 1) = start(m + 1) + start(m)
    end do
    do v = 1, mesh%nnode
      order(start(key(v))) = v
      start(key(v)) = start(key(v)) + 1
    end do
  end subroutine z_order

  !> j_floor with est(xs) = 2 (J(xs) - j_floor), J(xs) = 1/2 xs^T S xs - c^T xs: by (1.10),
  !> E(q, u~) = F(q) - 2 (f, u~) + ||u~||_1^2 with F(q) = 2 I(q) + ||f||^2, so
  !> E = 2 (J + shift) + ||f - u~||^2 + ||grad u~||^2 (sys%data_sq, f by the assembly's
  !> rule: a stopping criterion, not a bound).  u~ = 0 without u_primal.  The criterion's est
  !> leaves out the constant sum_T ||f - Pi_1 f||_T^2 (sys%data_osc_sq): the bound the
  !> estimator takes where it is smaller weights that term by h_T/pi, and on a small domain
  !> it is orders of magnitude above the rest of E, which would stop the iteration at once.
  pure real(dp) function nested_floor(sys) result(j_floor)
    type(hdiv_system_t), intent(in) :: sys
    j_floor = nested_floor_of(sys%shift, sys%data_sq, sys%data_osc_sq)
  end function nested_floor

  !> nested_floor from the parts of hdiv_system_t (shift, data_sq, data_osc_sq).
  pure real(dp) function nested_floor_of(shift, data_sq, data_osc_sq) result(j_floor)
    real(dp), intent(in) :: shift, data_sq, data_osc_sq
    j_floor = -shift - 0.5_dp * (data_sq - data_osc_sq)
  end function nested_floor_of

  !> The paper's Uzawa algorithm (Section 3) on the condensed system with B = the rows
  !> e_i^T of the bounded unknowns: S factorised once by CHOLMOD.
  subroutine solve_uzawa(mesh, sys, kind, settings, xs, res, st)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_system_t), intent(in) :: sys
    integer, intent(in) :: kind(:)
    type(dual_p1_settings_t), intent(in) :: settings
    real(dp), intent(inout) :: xs(:)
    type(dual_p1_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    type(rect_t) :: bmat
    type(cholmod_spd_t) :: chol
    type(uzawa_settings_t) :: uset
    type(uzawa_result_t) :: ures
    integer, allocatable :: rows(:), cols(:), perm(:), row_kind(:)
    real(dp), allocatable :: vals(:), z(:), zero(:), pts(:,:)
    integer :: m, i, ord, ist
    m = count(kind == BOUND_LOWER)
    allocate (rows(m), cols(m), vals(m), z(m), zero(m), row_kind(m), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 constraint rows', 6 * m, BYTES_REAL)) return
    allocate (pts(2, sys%a%n), stat=ist)
    if (alloc_failed(ist, st, 'the points of the RT1 unknowns', 2 * sys%a%n, BYTES_REAL)) return
    call hdiv_dof_points(mesh, pts)
    vals = 1.0_dp
    z = 0.0_dp
    zero = 0.0_dp
    row_kind = ROW_INEQUALITY
    m = 0
    do i = 1, size(kind)
      if (kind(i) /= BOUND_LOWER) cycle
      m = m + 1
      rows(m) = m
      cols(m) = i
    end do
    call rect_from_triplets(m, sys%a%n, rows, cols, vals, bmat, st)
    if (.not. is_ok(st)) return
    call select_ordering(settings%ordering, pts, sys%a, ord, perm, st)
    if (.not. is_ok(st)) return
    call chol%factor(sys%a, st, ord, perm)
    if (.not. is_ok(st)) return
    res%factorisations = 1
    res%nnz_factor = chol%chol%nnz_factor
    res%ordering = chol%chol%ordering
    uset%rho = settings%rho
    uset%tol = settings%tol
    uset%max_iter = settings%max_iter
    call uzawa_solve(chol, sys%b, bmat, row_kind, zero, xs, z, uset, ures, st)
    call chol%free()
    res%iterations = ures%iterations
    res%residual = ures%residual
    res%converged = ures%converged
    res%rho = ures%rho
    res%lambda_max = ures%lambda_max
    res%retries = ures%retries
  end subroutine solve_uzawa
end module dualsig_problem_dual_hdiv
