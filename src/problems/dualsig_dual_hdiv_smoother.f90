!> A matrix-free solver for the condensed RT1 dual problem of P1 (dualsig_problem_dual_hdiv)
!> from a close start: projected multiplicative Schwarz sweeps over the vertex patches (all
!> side unknowns of the edges at a vertex, the patches of the V-cycle's smoother in
!> dualsig_patch_schwarz), each patch's block and residual gathered from the condensed
!> systems of the triangles at the vertex (hdiv_condensed_element, kept per triangle),
!> never from an assembled matrix.  Every row of a patch unknown gets its entries from the
!> triangles at its edge, and both lie at the vertex, so the patch's block and residual are
!> exact.
!>
!> The problem is that of dualsig_problem_dual_hdiv: minimise J(x) = 1/2 x^T S x - c^T x
!> (S = sum_T S_T, c = sum_T c_T, the interior unknowns eliminated) subject to x_i >= 0 on
!> the bounded unknowns (q.nu at both ends of a boundary edge).  A patch step minimises J
!> over the patch's unknowns with the bounds handled in the patch (the unknowns whose
!> unconstrained step would go below 0 set to 0 and the rest solved again, until none
!> does), and against the feasible step along the first, unconstrained, direction cut at
!> the bound; the better of the two is taken when it decreases J, none otherwise.  So J
!> never increases, the field stays feasible after every step, and any field it returns
!> gives guaranteed bounds.
!>
!> Memory: per triangle its side unknowns, the packed 6x6 condensed matrix, the right-hand
!> side and the condensation (352 bytes), and the triangles at every node; no matrix, no
!> factors.  The sweeps are bound by memory latency, so everything is stored in the order
!> of the sweep: the nodes in the caller's order (e.g. along a Z-order curve), the
!> triangles and the side unknowns numbered as the patches first reach them.  The vectors
!> of hdiv_local_energy and hdiv_local_sweep are in that numbering of the side unknowns
!> (hdiv_local_permute; hdiv_local_recover returns the field in the mesh's).
module dualsig_dual_hdiv_smoother
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_elements_rt1, only: rt1_nside, rt1_reference_t, rt1_reference, rt1_matrix_degree
  use dualsig_assembly_dual_hdiv, only: hdiv_element_t, hdiv_condensed_element, hdiv_side_dofs
  use dualsig_load_data, only: load_data_t
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: hdiv_local_t, hdiv_local_build, hdiv_local_permute, hdiv_local_energy, hdiv_local_sweep, &
            hdiv_local_recover

  !> Entries of the packed lower triangle of a condensed 6x6 matrix.
  integer, parameter :: npack = rt1_nside * (rt1_nside + 1) / 2

  !> The condensed systems of the triangles of a mesh (hdiv_condensed_element) and the
  !> triangles at every node, in the sweep's numbering (module header): node position p
  !> (the p-th of the caller's order), triangle tn, side unknown i.
  type :: hdiv_local_t
    integer :: ntri = 0
    integer :: nside = 0                   !! side unknowns (2 nedge)
    integer :: max_patch = 0               !! most unknowns of a vertex patch
    integer, allocatable :: dofs(:,:)      !! (6, ntri) the side unknowns of each triangle
    real(dp), allocatable :: se(:,:)       !! (npack, ntri) condensed matrix, packed lower, by columns
    real(dp), allocatable :: ce(:,:)       !! (6, ntri) condensed right-hand side
    real(dp), allocatable :: rec(:,:,:)    !! (2, 7, ntri) rec_k (2 x 6), then rec_d
    integer, allocatable :: tri_of(:)      !! (ntri) the mesh's triangle of triangle tn
    integer, allocatable :: tperm(:)       !! (ntri) the mesh's triangle t is triangle tperm(t) here
    integer, allocatable :: perm(:)        !! (nside) side unknown i of the mesh is perm(i) here
    !> (npos+1) the triangles at node position p: node_tri(node_ptr(p):node_ptr(p+1)-1), with
    !> the node's local vertex number in each, node_corner
    integer, allocatable :: node_ptr(:), node_tri(:), node_corner(:)
    logical, allocatable :: node_boundary(:)   !! (npos) the node lies on the boundary
    real(dp) :: shift = 0.0_dp             !! as hdiv_system_t%shift
    real(dp) :: data_sq = 0.0_dp           !! as hdiv_system_t%data_sq
    real(dp) :: data_osc_sq = 0.0_dp       !! as hdiv_system_t%data_osc_sq
  end type hdiv_local_t

  !> Work arrays of one patch step (max_patch long), allocated once per sweep.
  type :: patch_work_t
    real(dp), allocatable :: a(:,:)        !! the patch's block of S
    real(dp), allocatable :: f(:,:)        !! Cholesky factor of its free part
    real(dp), allocatable :: r(:), x(:), d(:), d0(:), y(:)
    integer, allocatable :: list(:), idx(:)
    logical, allocatable :: at_zero(:), bnd(:)
    real(dp) :: dj = 0.0_dp                !! the change of J by the step d
  end type patch_work_t

contains

  !> The condensed system of every triangle of mesh (what assemble_dual_hdiv would add into
  !> its matrix; f, rule, u and load as there) and the triangles at every node, in the
  !> sweep's numbering for the nodes in `order` (each node once).  Out of memory:
  !> DS_ERR_MEMORY in st.
  subroutine hdiv_local_build(mesh, f, rule, order, loc, st, u, load, x0, j0)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    integer, intent(in) :: order(:)
    type(hdiv_local_t), intent(out) :: loc
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: u(:)
    type(load_data_t), intent(in), optional :: load
    !> side unknowns in the mesh's numbering (optional): j0 = J(x0) (hdiv_local_energy), summed
    !> on the way
    real(dp), intent(in), optional :: x0(:)
    real(dp), intent(out), optional :: j0
    type(rt1_reference_t) :: ref
    type(hdiv_element_t) :: el
    real(dp) :: xt(rt1_nside)
    integer :: t, tn, ist
    loc%ntri = mesh%ntri
    loc%nside = 2 * mesh%nedge
    call node_triangles(mesh, order, loc, st)
    if (st%code /= 0) return
    call sweep_numbering(mesh, loc, st)
    if (st%code /= 0) return
    allocate (loc%se(npack, mesh%ntri), loc%ce(rt1_nside, mesh%ntri), loc%rec(2, 7, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the condensed RT1 systems of the triangles', (npack + rt1_nside + 14) * mesh%ntri, &
                     BYTES_REAL)) return
    ref = rt1_reference(tri_rule(rt1_matrix_degree))
    if (present(j0)) j0 = 0.0_dp
    do t = 1, mesh%ntri
      call hdiv_condensed_element(mesh, t, f, rule, ref, el, u, load)
      if (present(x0) .and. present(j0)) then
        xt = x0(el%dofs)
        j0 = j0 + 0.5_dp * dot_product(xt, matmul(el%se, xt)) - dot_product(el%ce, xt)
      end if
      tn = loc%tperm(t)
      loc%data_osc_sq = loc%data_osc_sq + el%osc_sq
      loc%data_sq = loc%data_sq + el%data_sq
      loc%shift = loc%shift + el%shift
      loc%se(:, tn) = pack_lower(el%se)
      loc%ce(:, tn) = el%ce
      loc%rec(:, 1:rt1_nside, tn) = el%rec_k
      loc%rec(:, 7, tn) = el%rec_d
    end do
  end subroutine hdiv_local_build

  !> The triangles at every node position p (node order(p)) with the node's local vertex
  !> number in each, the nodes on the boundary, and the largest vertex patch: two unknowns
  !> per edge at the node, at most one edge more than triangles.  Triangles in the mesh's
  !> numbering (sweep_numbering renumbers them).
  subroutine node_triangles(mesh, order, loc, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: order(:)
    type(hdiv_local_t), intent(inout) :: loc
    type(status_t), intent(inout) :: st
    integer, allocatable :: fill(:), rank(:)
    integer :: t, k, p, ist
    allocate (rank(mesh%nnode), loc%node_ptr(mesh%nnode + 1), loc%node_tri(3 * mesh%ntri), &
              loc%node_corner(3 * mesh%ntri), loc%node_boundary(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the triangles at the nodes', 3 * mesh%nnode + 1 + 6 * mesh%ntri, BYTES_INT)) return
    do p = 1, mesh%nnode
      rank(order(p)) = p
    end do
    loc%node_boundary = mesh%node_on_boundary(order)
    loc%node_ptr = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        p = rank(mesh%tri(k, t))
        loc%node_ptr(p + 1) = loc%node_ptr(p + 1) + 1
      end do
    end do
    loc%max_patch = 2 * (maxval(loc%node_ptr) + 1)
    loc%node_ptr(1) = 1
    do p = 1, mesh%nnode
      loc%node_ptr(p + 1) = loc%node_ptr(p + 1) + loc%node_ptr(p)
    end do
    fill = loc%node_ptr(1:mesh%nnode)
    do t = 1, mesh%ntri
      do k = 1, 3
        p = rank(mesh%tri(k, t))
        loc%node_tri(fill(p)) = t
        loc%node_corner(fill(p)) = k
        fill(p) = fill(p) + 1
      end do
    end do
  end subroutine node_triangles

  !> The sweep's numbering: the triangles (loc%tri_of, and node_tri renumbered) and the side
  !> unknowns (loc%perm) in the order the vertex patches first reach them.  Every side
  !> unknown is in a patch (an edge has two ends).
  subroutine sweep_numbering(mesh, loc, st)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_local_t), intent(inout) :: loc
    type(status_t), intent(inout) :: st
    integer :: it, t, tn, kv, l, g, next_t, next_i, ist
    real(dp) :: sgn(rt1_nside)
    allocate (loc%tperm(mesh%ntri), loc%tri_of(mesh%ntri), loc%perm(loc%nside), loc%dofs(rt1_nside, mesh%ntri), &
              stat=ist)
    if (alloc_failed(ist, st, 'the numbering of the patch sweeps', 8 * mesh%ntri + loc%nside, BYTES_INT)) return
    loc%tperm = 0
    loc%perm = 0
    next_t = 0
    next_i = 0
    do it = 1, size(loc%node_tri)
      t = loc%node_tri(it)
      kv = loc%node_corner(it)
      if (loc%tperm(t) == 0) then
        next_t = next_t + 1
        loc%tperm(t) = next_t
        loc%tri_of(next_t) = t
        call hdiv_side_dofs(mesh, t, loc%dofs(:, next_t), sgn)     ! the mesh's numbering for now
      end if
      tn = loc%tperm(t)
      do l = 1, rt1_nside
        if (.not. at_corner(l, kv)) cycle
        g = loc%dofs(l, tn)
        if (loc%perm(g) /= 0) cycle
        next_i = next_i + 1
        loc%perm(g) = next_i
      end do
      loc%node_tri(it) = tn
    end do
    do tn = 1, mesh%ntri
      loc%dofs(:, tn) = loc%perm(loc%dofs(:, tn))
    end do
  end subroutine sweep_numbering

  !> Local side unknown l (of side (l+1)/2) belongs to the patch of local vertex kv: its side
  !> is kv (a_kv a_kv+1) or kv - 1.
  pure logical function at_corner(l, kv)
    integer, intent(in) :: l, kv
    at_corner = (l + 1) / 2 == kv .or. (l + 1) / 2 == mod(kv + 1, 3) + 1
  end function at_corner

  !> xp = xs in the sweep's numbering of the side unknowns (xp(perm(i)) = xs(i)).
  pure subroutine hdiv_local_permute(loc, xs, xp)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xs(:)
    real(dp), intent(out) :: xp(:)
    xp(loc%perm) = xs(1:loc%nside)
  end subroutine hdiv_local_permute

  !> J(xs) = 1/2 xs^T S xs - c^T xs, summed by triangles.
  pure real(dp) function hdiv_local_energy(loc, xs) result(j)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xs(:)
    real(dp) :: se(rt1_nside, rt1_nside), xt(rt1_nside)
    integer :: t
    j = 0.0_dp
    do t = 1, loc%ntri
      se = unpack_lower(loc%se(:, t))
      xt = xs(loc%dofs(:, t))
      j = j + 0.5_dp * dot_product(xt, matmul(se, xt)) - dot_product(loc%ce(:, t), xt)
    end do
  end function hdiv_local_energy

  !> The field vector x in the mesh's numbering (side unknowns, then 2 interior unknowns per
  !> triangle) from the side unknowns xp in the sweep's: the interior ones from each
  !> triangle's condensation.
  pure subroutine hdiv_local_recover(loc, xp, x)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xp(:)
    real(dp), intent(out) :: x(:)
    integer :: tn, t, n
    n = loc%nside
    x(1:n) = xp(loc%perm)
    do t = 1, loc%ntri
      tn = loc%tperm(t)
      x(n + 2 * t - 1:n + 2 * t) = loc%rec(:, 7, tn) - matmul(loc%rec(:, 1:rt1_nside, tn), xp(loc%dofs(:, tn)))
    end do
  end subroutine hdiv_local_recover

  !> One projected multiplicative sweep over the vertex patches, in the order of loc (module
  !> header), on the side unknowns xs in the sweep's numbering: xs stays feasible
  !> (bounded(i): xs(i) >= 0, same numbering) and J decreases by dj >= 0.  Out of memory:
  !> DS_ERR_MEMORY in st.
  subroutine hdiv_local_sweep(loc, bounded, xs, dj, st)
    type(hdiv_local_t), intent(in) :: loc
    logical, intent(in) :: bounded(:)
    real(dp), intent(inout) :: xs(:)
    real(dp), intent(out) :: dj
    type(status_t), intent(inout) :: st
    type(patch_work_t) :: w
    integer, allocatable :: pos(:)
    integer :: iv, m, ist, mp
    dj = 0.0_dp
    mp = loc%max_patch
    allocate (pos(loc%nside), source=0, stat=ist)
    if (alloc_failed(ist, st, 'the patch positions of the RT1 unknowns', loc%nside, BYTES_INT)) return
    allocate (w%a(mp, mp), w%f(mp, mp), w%r(mp), w%d(mp), w%d0(mp), w%y(mp), w%list(mp), w%idx(mp), &
              w%at_zero(mp), w%bnd(mp), w%x(mp), stat=ist)
    if (alloc_failed(ist, st, 'the block of a vertex patch', mp * (2 * mp + 8), BYTES_REAL)) return
    do iv = 1, size(loc%node_boundary)
      call patch_system(loc, iv, xs, pos, w%list, m, w%a, w%r)
      if (m > 0) then
        w%x(1:m) = xs(w%list(1:m))
        ! only the patches of boundary nodes hold bounded unknowns (those of boundary edges)
        if (loc%node_boundary(iv)) then
          w%bnd(1:m) = bounded(w%list(1:m))
          call patch_step(w, m)
        else
          w%bnd(1:m) = .false.
          call free_patch_step(w, m)
        end if
        if (w%dj < 0.0_dp) then
          xs(w%list(1:m)) = w%x(1:m) + w%d(1:m)
          where (w%bnd(1:m)) xs(w%list(1:m)) = max(xs(w%list(1:m)), 0.0_dp)
          dj = dj - w%dj
        end if
      end if
      pos(w%list(1:m)) = 0
    end do
  end subroutine hdiv_local_sweep

  !> The vertex patch of node position p: its unknowns list(1:m) (pos(list(k)) = k on
  !> return; the caller resets pos), its block a(1:m, 1:m) of S and its residual
  !> r = (c - S xs) on it, from the triangles at the node.  The sides of triangle t through
  !> the node a_kv are its local sides kv (a_kv a_kv+1) and kv - 1: local unknowns 2kv-1,
  !> 2kv, 2km-1, 2km.
  pure subroutine patch_system(loc, p, xs, pos, list, m, a, r)
    type(hdiv_local_t), intent(in) :: loc
    integer, intent(in) :: p
    real(dp), intent(in) :: xs(:)
    integer, intent(inout) :: pos(:)
    integer, intent(inout) :: list(:)
    integer, intent(out) :: m
    real(dp), intent(inout) :: a(:,:), r(:)
    real(dp) :: xt(rt1_nside), s, se(rt1_nside, rt1_nside)
    integer :: it, t, kv, km, ia, ib, l, l2, i, g, lp(4), ip(4)
    m = 0
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      kv = loc%node_corner(it)
      km = mod(kv + 1, 3) + 1
      lp = [2 * kv - 1, 2 * kv, 2 * km - 1, 2 * km]
      do ia = 1, 4
        g = loc%dofs(lp(ia), t)
        if (pos(g) /= 0) cycle
        m = m + 1
        list(m) = g
        pos(g) = m
        r(m) = 0.0_dp
        a(1:m, m) = 0.0_dp
        a(m, 1:m) = 0.0_dp
      end do
    end do
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      kv = loc%node_corner(it)
      km = mod(kv + 1, 3) + 1
      lp = [2 * kv - 1, 2 * kv, 2 * km - 1, 2 * km]
      xt = xs(loc%dofs(:, t))
      ip = pos(loc%dofs(lp, t))
      se = unpack_lower(loc%se(:, t))
      do ia = 1, 4
        l = lp(ia)
        i = ip(ia)
        s = loc%ce(l, t)
        do l2 = 1, rt1_nside
          s = s - se(l2, l) * xt(l2)
        end do
        r(i) = r(i) + s
        do ib = 1, 4
          a(i, ip(ib)) = a(i, ip(ib)) + se(lp(ib), l)
        end do
      end do
    end do
  end subroutine patch_system

  !> patch_step for a patch without bounded unknowns: w%d = a^{-1} r, w%dj = -r^T d / 2 (or
  !> d = 0, dj = 0 when the block is not positive definite).
  pure subroutine free_patch_step(w, m)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    integer :: i, j, ierr
    do j = 1, m
      do i = j, m
        w%f(i, j) = w%a(i, j)
      end do
    end do
    w%d(1:m) = w%r(1:m)
    call spd_solve_in_place(m, w%f, w%d, ierr)
    w%dj = -0.5_dp * dot_product(w%r(1:m), w%d(1:m))
    if (ierr /= 0 .or. .not. w%dj < 0.0_dp) then
      w%d(1:m) = 0.0_dp
      w%dj = 0.0_dp
    end if
  end subroutine free_patch_step

  !> The step w%d of one patch of m unknowns (module header) for its block w%a (SPD),
  !> residual w%r, values w%x and bounds (w%bnd: x + d >= 0), and the change of J it makes,
  !> w%dj = 1/2 d^T a d - r^T d (< 0; 0 with d = 0 when no feasible step decreases J or a
  !> block is not positive definite).
  pure subroutine patch_step(w, m)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    real(dp) :: alpha, dj_cut
    integer :: round, ierr, i
    if (.not. any(w%bnd(1:m))) then
      call free_patch_step(w, m)
      return
    end if
    w%dj = 0.0_dp
    w%at_zero(1:m) = .false.
    call solve_with_zeros(w, m, ierr)
    if (ierr /= 0) then
      w%d(1:m) = 0.0_dp
      return
    end if
    w%d0(1:m) = w%d(1:m)
    do round = 1, m
      if (.not. any(w%bnd(1:m) .and. .not. w%at_zero(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp)) exit
      where (w%bnd(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp) w%at_zero(1:m) = .true.
      call solve_with_zeros(w, m, ierr)
      if (ierr /= 0) exit
    end do
    if (ierr /= 0 .or. any(w%bnd(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp)) w%d(1:m) = 0.0_dp
    w%dj = 0.5_dp * dot_product(w%d(1:m), matmul(w%a(1:m, 1:m), w%d(1:m))) - dot_product(w%r(1:m), w%d(1:m))
    ! the unconstrained direction cut at the first bound: J changes by (alpha^2/2 - alpha) r^T d0
    alpha = 1.0_dp
    do i = 1, m
      if (w%bnd(i) .and. w%d0(i) < 0.0_dp) alpha = min(alpha, w%x(i) / (-w%d0(i)))
    end do
    dj_cut = (0.5_dp * alpha**2 - alpha) * dot_product(w%r(1:m), w%d0(1:m))
    if (dj_cut < w%dj) then
      w%d(1:m) = alpha * w%d0(1:m)
      w%dj = dj_cut
    end if
    if (.not. w%dj < 0.0_dp) then
      w%d(1:m) = 0.0_dp
      w%dj = 0.0_dp
    end if
  end subroutine patch_step

  !> w%d minimising 1/2 d^T a d - r^T d over the patch's m unknowns with d_i = -x_i where
  !> w%at_zero(i) (those unknowns go to 0): the block of the others copied to w%f and solved
  !> there (spd_solve_in_place).  ierr /= 0 when that block is not positive definite.
  pure subroutine solve_with_zeros(w, m, ierr)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    integer, intent(out) :: ierr
    integer :: nf, i, j
    nf = 0
    do i = 1, m
      if (w%at_zero(i)) then
        w%d(i) = -w%x(i)
      else
        w%d(i) = 0.0_dp
        nf = nf + 1
        w%idx(nf) = i
      end if
    end do
    ierr = 0
    if (nf == 0) return
    do j = 1, nf
      w%y(j) = w%r(w%idx(j)) - dot_product(w%a(w%idx(j), 1:m), w%d(1:m))
      do i = j, nf
        w%f(i, j) = w%a(w%idx(i), w%idx(j))
      end do
    end do
    call spd_solve_in_place(nf, w%f, w%y, ierr)
    if (ierr /= 0) return
    w%d(w%idx(1:nf)) = w%y(1:nf)
  end subroutine solve_with_zeros

  !> y = F^{-1} y for the SPD matrix F whose lower triangle is f(1:n, 1:n): symmetric
  !> Gaussian elimination (F = L D L^T) on the lower triangle with y carried along, one
  !> reciprocal per pivot, then the back substitution with L^T.  ierr = j > 0 when pivot j
  !> is not positive (F not positive definite).
  pure subroutine spd_solve_in_place(n, f, y, ierr)
    integer, intent(in) :: n
    real(dp), intent(inout) :: f(:,:), y(:)
    integer, intent(out) :: ierr
    integer :: i, j, k
    real(dp) :: rpiv, s, fkj
    ierr = 0
    do j = 1, n
      if (.not. f(j, j) > 0.0_dp) then
        ierr = j
        return
      end if
      rpiv = 1.0_dp / f(j, j)
      do i = j + 1, n                  ! column j of L, scaled; the trailing lower triangle updated
        f(i, j) = f(i, j) * rpiv
      end do
      do k = j + 1, n
        fkj = f(k, j) * f(j, j)
        do i = k, n
          f(i, k) = f(i, k) - f(i, j) * fkj
        end do
        y(k) = y(k) - fkj * y(j) * rpiv
      end do
      y(j) = y(j) * rpiv
    end do
    do j = n, 1, -1                    ! L^T y = D^{-1} z
      s = y(j)
      do i = j + 1, n
        s = s - f(i, j) * y(i)
      end do
      y(j) = s
    end do
  end subroutine spd_solve_in_place

  !> The lower triangle of the symmetric 6x6 matrix s, column by column.
  pure function pack_lower(s) result(p)
    real(dp), intent(in) :: s(rt1_nside, rt1_nside)
    real(dp) :: p(npack)
    integer :: i, j, k
    k = 0
    do j = 1, rt1_nside
      do i = j, rt1_nside
        k = k + 1
        p(k) = s(i, j)
      end do
    end do
  end function pack_lower

  !> The symmetric 6x6 matrix of its packed lower triangle p (pack_lower).
  pure function unpack_lower(p) result(s)
    real(dp), intent(in) :: p(npack)
    real(dp) :: s(rt1_nside, rt1_nside)
    integer :: i, j, k
    k = 0
    do j = 1, rt1_nside
      do i = j, rt1_nside
        k = k + 1
        s(i, j) = p(k)
        s(j, i) = p(k)
      end do
    end do
  end function unpack_lower
end module dualsig_dual_hdiv_smoother
