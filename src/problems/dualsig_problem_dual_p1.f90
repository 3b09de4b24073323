!> The dual problem of P1 (Section 3): q in [V_h]^2 minimising I(q) (3.1') subject to
!> q.nu >= 0 on Gamma, written as (3.3)-(3.4): min 1/2 y^T A y - b^T y, B y >= 0.
!>
!> Constraint rows (the matrix B of (3.4)).  On a straight side q.nu is linear, so it is
!> >= 0 on the side iff it is >= 0 at both end nodes with that side's normal.  Hence:
!> - a boundary node inside a side (no corner) gives ONE row: nu . q(i) >= 0, nu the
!>   outward unit normal of its two (collinear) boundary edges;
!> - a polygon corner gives TWO rows: nu_in . q(i) >= 0 and nu_out . q(i) >= 0, with the
!>   normals of the incoming and the outgoing boundary edge (boundary edges run with the
!>   domain on their left, see dualsig_mesh).
!> Rows are numbered in the order of the boundary nodes 1..nnode; at a corner the
!> nu_in row comes first.
!>
!> Change of variables for the feasible solver: q(i) = T_i s(i) with
!> - T_i = I at interior nodes (s free);
!> - T_i = [nu tau] (columns; tau = (-nu_2, nu_1)) on a side: s_1 = q.nu >= 0, s_2 = q.tau free;
!> - T_i = N_i^{-1}, N_i = [nu_in^T; nu_out^T], at a corner: s = (q.nu_in, q.nu_out) >= 0.
!> Then B T is a selection of components of s, and q.nu >= 0 become simple bounds s_k >= 0.
!>
!> Solvers (dual_p1_solve):
!> - 'uzawa': the paper's algorithm on (A, B) in the original variables, A factorised once
!>   by CHOLMOD; its last iterate is made feasible by dual_p1_feasible_q;
!> - 'active_set': the primal-dual active-set method on the transformed problem
!>   (T^T A T, T^T b, s_k >= 0), whose solution is feasible by construction.
module dualsig_problem_dual_p1
  use dualsig_kinds, only: dp, i8
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_sparse, only: csr_t, rect_t, rect_from_triplets
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_sparse_direct, only: ORDERING_AMD, ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: select_ordering
  use dualsig_spd_solver, only: cholmod_spd_t
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER
  use dualsig_solver_uzawa, only: uzawa_settings_t, uzawa_result_t, uzawa_solve
  use dualsig_qp_types, only: ROW_INEQUALITY
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_assembly_dual_p1, only: dual_p1_dof, assemble_dual_p1
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_MESH, DS_ERR_INPUT
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: dual_p1_result_from_active_set
  public :: dual_p1_transforms, dual_p1_constraint_rows, dual_p1_nodewise, &
            dual_p1_feasible_q, dual_p1_settings_t, dual_p1_result_t, dual_p1_solve, dual_p1_ordering

  type :: dual_p1_settings_t
    character(len=16) :: method = 'active_set'   !! 'active_set' or 'uzawa'
    real(dp) :: rho = 0.0_dp                     !! Uzawa step, 0 = automatic
    real(dp) :: tol = 1.0e-10_dp                 !! Uzawa tolerance (relative natural residual)
    integer :: max_iter = 20000                  !! Uzawa iterations / active-set changes
    integer :: ordering = ORDERING_AMD           !! CHOLMOD ordering
    !> RT1 'nested', the last level of a uniform run (dualsig_problem_dual_hdiv, solve_smoothed):
    !> the part of est its sweeps may leave (predicted), in est's units; 0: algebraic_share
    !> of the sweeps' own est (which leaves out what est_pw weights down, so it is looser)
    real(dp) :: algebraic_est_tol = 0.0_dp
    real(dp) :: algebraic_share = 1.0e-3_dp
  end type dual_p1_settings_t

  type :: dual_p1_result_t
    integer :: iterations = 0          !! Uzawa iterations or active-set iterations
    integer :: factorisations = 0      !! CHOLMOD (re)factorisations
    integer :: lowrank_solves = 0      !! active-set iterations done by bordering
    real(dp) :: residual = 0.0_dp      !! Uzawa residual or KKT residual of the active-set solve
    logical :: converged = .false.
    real(dp) :: rho = 0.0_dp           !! Uzawa step used
    real(dp) :: lambda_max = 0.0_dp    !! power-iteration estimate (automatic rho)
    integer :: retries = 0             !! automatic rho halvings
    integer(i8) :: nnz_factor = 0      !! nonzeros of the Cholesky factor
    character(len=8) :: ordering = ''  !! ordering chosen by CHOLMOD
    integer :: nconstraints = 0        !! rows of B
    integer :: nactive = 0             !! constraints active at the solution
  end type dual_p1_result_t

  !> |det N| below this marks a corner whose two normals are (anti)parallel (a slit tip).
  real(dp), parameter :: min_corner_det = 1.0e-8_dp

contains

  !> The counters of an active-set solve (iterations, factorisations, bordered solves, KKT
  !> residual, convergence, factor size, ordering) copied into the dual's result.
  subroutine dual_p1_result_from_active_set(ares, res)
    type(active_set_result_t), intent(in) :: ares
    type(dual_p1_result_t), intent(inout) :: res
    res%iterations = ares%iterations
    res%factorisations = ares%factorisations
    res%lowrank_solves = ares%lowrank_solves
    res%residual = ares%kkt_residual
    res%converged = ares%converged
    res%nnz_factor = ares%nnz_factor
    res%ordering = ares%ordering
  end subroutine dual_p1_result_from_active_set

  !> Solve the dual problem (3.2) on `mesh` and return a FEASIBLE field q (interleaved
  !> nodal values, 2 nnode): q.nu >= 0 at every boundary node with the normals of its sides.
  !> st carries DS_WARN_NOT_CONVERGED when the iteration limit was reached (q is still
  !> feasible and usable in the bounds).
  !> q_start (optional, 2 nnode): a start for the active-set solver, e.g. the coarser
  !> level's field interpolated.  u_primal (optional, nnode): the primal solution on this
  !> mesh; by complementarity ((q.nu) u = 0 on Gamma) the constraints q.nu >= 0 are predicted
  !> active where u > 0, which is a better first guess than an interpolated field
  !> (preferred when both are given).
  subroutine dual_p1_solve(mesh, f, rule, settings, q, res, st, q_start, u_primal)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(dual_p1_settings_t), intent(in) :: settings
    real(dp), allocatable, intent(out) :: q(:)
    type(dual_p1_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: q_start(:)
    real(dp), intent(in), optional :: u_primal(:)
    real(dp), allocatable :: t(:,:,:), tinv(:,:,:), b(:), y(:), z(:), s(:), zero(:)
    integer, allocatable :: kind(:), row_node(:), row_kind(:)
    type(csr_t) :: a
    type(rect_t) :: bmat
    type(cholmod_spd_t) :: chol
    type(uzawa_settings_t) :: uset
    type(uzawa_result_t) :: ures
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    integer :: i, ord, ist
    integer, allocatable :: perm(:)

    call dual_p1_transforms(mesh, t, tinv, kind, st)
    if (st%code /= 0) return
    allocate (b(2 * mesh%nnode), q(2 * mesh%nnode), y(2 * mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the dual P1 vectors', 6 * mesh%nnode, BYTES_REAL)) return
    res%nconstraints = count(mesh%node_on_boundary) + count(mesh%node_is_corner)
    select case (trim(settings%method))
    case ('uzawa')
      call assemble_dual_p1(mesh, f, rule, a, b, st=st)
      if (.not. is_ok(st)) return
      call dual_p1_ordering(mesh, a, settings%ordering, ord, perm, st)
      if (st%code /= 0) return
      call chol%factor(a, st, ord, perm)
      if (st%code /= 0) return
      res%factorisations = 1
      res%nnz_factor = chol%chol%nnz_factor
      res%ordering = chol%chol%ordering
      call dual_p1_constraint_rows(mesh, bmat, row_node, st)
      if (.not. is_ok(st)) return
      allocate (z(bmat%m), row_kind(bmat%m), zero(bmat%m), stat=ist)
      if (alloc_failed(ist, st, 'the dual P1 constraints', 3 * bmat%m, BYTES_REAL)) return
      z = 0.0_dp
      row_kind = ROW_INEQUALITY
      zero = 0.0_dp
      uset%rho = settings%rho
      uset%tol = settings%tol
      uset%max_iter = settings%max_iter
      call uzawa_solve(chol, b, bmat, row_kind, zero, y, z, uset, ures, st)
      call chol%free()
      if (.not. is_ok(st)) return
      res%iterations = ures%iterations
      res%residual = ures%residual
      res%converged = ures%converged
      res%rho = ures%rho
      res%lambda_max = ures%lambda_max
      res%retries = ures%retries
      res%nactive = count(z > 0.0_dp)
      call dual_p1_feasible_q(t, tinv, kind, y, q)
    case ('active_set')
      call assemble_dual_p1(mesh, f, rule, a, b, t, st)
      if (.not. is_ok(st)) return
      allocate (s(2 * mesh%nnode), zero(2 * mesh%nnode), stat=ist)
      if (alloc_failed(ist, st, 'the dual P1 vectors', 4 * mesh%nnode, BYTES_REAL)) return
      s = 0.0_dp
      zero = 0.0_dp
      if (present(u_primal)) then
        ! held (q.nu = 0) where the primal solution separates, free where it is in contact
        do i = 1, mesh%nnode
          if (mesh%node_on_boundary(i)) s(2 * i - 1:2 * i) = merge(0.0_dp, 1.0_dp, u_primal(i) > 0.0_dp)
        end do
        where (kind /= BOUND_LOWER) s = 0.0_dp
      else if (present(q_start)) then
        call dual_p1_nodewise(tinv, q_start, s)
        where (kind == BOUND_LOWER) s = max(s, 0.0_dp)
      end if
      aset%max_iter = settings%max_iter
      call dual_p1_ordering(mesh, a, settings%ordering, aset%ordering, aset%perm, st)
      if (st%code /= 0) return
      call active_set_solve(a, b, kind, zero, s, aset, ares, st)
      if (.not. is_ok(st)) return
      call dual_p1_result_from_active_set(ares, res)
      res%nactive = ares%nactive
      call dual_p1_nodewise(t, s, y)
      call dual_p1_feasible_q(t, tinv, kind, y, q)
    case default
      call set_error(st, DS_ERR_INPUT, 'dual P1: unknown method "' // trim(settings%method) // &
        '"; expected active_set or uzawa')
    end select
  end subroutine dual_p1_solve

  !> Per-node transforms T (2,2,nnode), their inverses, and the bound kind of every
  !> component of s (BOUND_LOWER for s = q.nu components, BOUND_FREE otherwise).
  subroutine dual_p1_transforms(mesh, t, tinv, kind, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), allocatable, intent(out) :: t(:,:,:), tinv(:,:,:)
    integer, allocatable, intent(out) :: kind(:)
    type(status_t), intent(out) :: st
    real(dp) :: nu_in(2), nu_out(2), det, nmat(2, 2)
    integer :: i, ist
    allocate (t(2, 2, mesh%nnode), tinv(2, 2, mesh%nnode), kind(2 * mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the dual P1 node transforms', 9 * mesh%nnode, BYTES_REAL)) return
    kind = BOUND_FREE
    do i = 1, mesh%nnode
      t(:, :, i) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [2, 2])
      tinv(:, :, i) = t(:, :, i)
      if (.not. mesh%node_on_boundary(i)) cycle
      nu_in = mesh%bedge_normal(:, mesh%node_bedge_in(i))
      nu_out = mesh%bedge_normal(:, mesh%node_bedge_out(i))
      if (.not. mesh%node_is_corner(i)) then
        ! columns nu and tau; orthogonal, so the inverse is the transpose
        t(:, 1, i) = nu_out
        t(:, 2, i) = [-nu_out(2), nu_out(1)]
        tinv(:, :, i) = transpose(t(:, :, i))
        kind(dual_p1_dof(i, 1)) = BOUND_LOWER
      else
        nmat(1, :) = nu_in
        nmat(2, :) = nu_out
        det = nmat(1, 1) * nmat(2, 2) - nmat(1, 2) * nmat(2, 1)
        if (abs(det) < min_corner_det) then
          call set_error(st, DS_ERR_MESH, 'dual P1: the boundary folds back at node ' // itoa(i) // &
            ' (a slit: the two normals are parallel); not supported by the P1 dual')
          return
        end if
        tinv(:, :, i) = nmat
        t(:, :, i) = reshape([nmat(2, 2), -nmat(2, 1), -nmat(1, 2), nmat(1, 1)], [2, 2]) / det
        kind(dual_p1_dof(i, [1, 2])) = BOUND_LOWER
      end if
    end do
  end subroutine dual_p1_transforms

  !> The constraint matrix B of (3.4) in the original variables y (see the module header
  !> for the row convention) and, for each row, its boundary node.  Out of memory:
  !> DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_p1_constraint_rows(mesh, b, row_node, st)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(out) :: b
    integer, allocatable, intent(out) :: row_node(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: r(:), c(:)
    real(dp), allocatable :: v(:)
    real(dp) :: nu(2)
    integer :: i, m, k, pass, ist
    m = count(mesh%node_on_boundary) + count(mesh%node_is_corner)
    allocate (r(2 * m), c(2 * m), v(2 * m), row_node(m), stat=ist)
    if (alloc_failed(ist, st, 'the dual P1 constraint rows', 8 * m, BYTES_REAL)) return
    m = 0
    k = 0
    do i = 1, mesh%nnode
      if (.not. mesh%node_on_boundary(i)) cycle
      do pass = 1, merge(2, 1, mesh%node_is_corner(i))
        if (pass == 1 .and. mesh%node_is_corner(i)) then
          nu = mesh%bedge_normal(:, mesh%node_bedge_in(i))
        else
          nu = mesh%bedge_normal(:, mesh%node_bedge_out(i))
        end if
        m = m + 1
        row_node(m) = i
        r(k + 1:k + 2) = m
        c(k + 1:k + 2) = dual_p1_dof(i, [1, 2])
        v(k + 1:k + 2) = nu
        k = k + 2
      end do
    end do
    call rect_from_triplets(m, 2 * mesh%nnode, r, c, v, b, st)
  end subroutine dual_p1_constraint_rows

  !> w(node i) = blocks(:,:,i) v(node i) for node-interleaved vectors: y = T s with the
  !> transforms, s = T^{-1} y with their inverses.
  pure subroutine dual_p1_nodewise(blocks, v, w)
    real(dp), intent(in) :: blocks(:,:,:)
    real(dp), intent(in) :: v(:)
    real(dp), intent(out) :: w(:)
    integer :: i
    do i = 1, size(blocks, 3)
      w(2 * i - 1:2 * i) = matmul(blocks(:, :, i), v(2 * i - 1:2 * i))
    end do
  end subroutine dual_p1_nodewise

  !> The feasible field used by the bounds: q_f = T max(T^{-1} y, 0), the maximum taken on
  !> the bounded components only.  q_f . nu = s_k >= 0 at every boundary node by
  !> construction; q_f = y up to rounding when y is feasible already.
  pure subroutine dual_p1_feasible_q(t, tinv, kind, y, qf)
    real(dp), intent(in) :: t(:,:,:), tinv(:,:,:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: y(:)
    real(dp), intent(out) :: qf(:)
    real(dp) :: s(size(y))
    call dual_p1_nodewise(tinv, y, s)
    where (kind == BOUND_LOWER) s = max(s, 0.0_dp)
    call dual_p1_nodewise(t, s, qf)
  end subroutine dual_p1_feasible_q

  !> The CHOLMOD ordering for the dual unknowns: `ordering` itself, or for ORDERING_GEOMETRIC
  !> the choice of geometric_ordering (nested dissection, both unknowns of node i at its point).
  subroutine dual_p1_ordering(mesh, a, ordering, ord, perm, st)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(in) :: a
    integer, intent(in) :: ordering
    integer, intent(out) :: ord
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    real(dp), allocatable :: xy(:,:)
    integer :: i, ist
    allocate (xy(2, 2 * mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the points of the dual P1 unknowns', 4 * mesh%nnode, BYTES_REAL)) return
    do i = 1, mesh%nnode
      xy(:, 2 * i - 1) = mesh%xy(:, i)
      xy(:, 2 * i) = mesh%xy(:, i)
    end do
    call select_ordering(ordering, xy, a, ord, perm, st)
  end subroutine dual_p1_ordering
end module dualsig_problem_dual_p1
