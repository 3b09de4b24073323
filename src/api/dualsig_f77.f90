!> FORTRAN 77 interface of dualsig: two external subroutines callable without any module,
!> with explicit-shape (or assumed-size) arrays and DOUBLE PRECISION / INTEGER arguments.
!>
!>   DSBQP   the bound-constrained QP  min 1/2 x^T A x - F^T x  with a symmetric CSR matrix
!>           (1-based, both triangles stored) by projected SOR or the active-set method;
!>   DSSIGN  the whole primal + dual analysis of problem P1 or P2 on a caller's mesh.
!>
!> This file holds no module (the one-module-per-file rule is kept): the two routines are
!> external procedures whose names the linker sees as dsbqp_ and dssign_ (gfortran).
!> Conventions as in LAPACK: INFO = 0 success, INFO = -k argument k is invalid (checked in
!> argument order, the first bad one is named), INFO > 0 a result with a warning, or a
!> failure (values documented at each routine).  Nothing is printed unless an option asks
!> for it (DSSIGN IOPT(4)); DSBQP never prints.

!> DSBQP: minimise 1/2 x^T A x - F^T x subject to, for every i,
!>   KIND(i) = 0: x(i) free;  1: x(i) >= BND(i);  2: x(i) = BND(i),
!> for A symmetric positive definite given in CSR form: row i is A(IA(i):IA(i+1)-1) in the
!> columns JA(IA(i):IA(i+1)-1), 1-based, any column order within a row, both triangles
!> stored, no duplicate entries, the diagonal present.
!>   METHOD 1: projected SOR with relaxation OMEGA in (0, 2), at most MAXIT sweeps;
!>   METHOD 2: the primal-dual active-set method (CHOLMOD, AMD ordering), at most MAXIT
!>             active-set changes, then projected SOR to TOL (OMEGA not referenced).
!> X: the start on entry (projected on the bounds first), the solution on exit.
!> ITER: sweeps (METHOD 1) or active-set iterations (METHOD 2).
!> RES: the relative KKT residual of the returned X (dualsig_solver_psor kkt_residual).
!> INFO: 0 RES <= TOL; 1 RES > TOL (iteration limit reached; X is the feasible last
!>       iterate); 2 numerical failure (A not positive definite: the Cholesky factorisation
!>       failed or the iterate became non-finite; X is not a solution);
!>       -k argument k is invalid (k = 1..12, positions as in the argument list).
subroutine dsbqp(n, ia, ja, a, f, kind, bnd, x, method, omega, tol, maxit, iter, res, info)
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t, csr_is_symmetric
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_qp_types, only: BOUND_FREE, BOUND_FIXED
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_status, only: status_t, is_ok
  implicit none
  integer, intent(in) :: n                 !! order of A (>= 1)
  integer, intent(in) :: ia(n + 1)         !! row pointers, IA(1) = 1, non-decreasing
  integer, intent(in) :: ja(*)             !! column indices, IA(N+1)-1 of them
  real(dp), intent(in) :: a(*)             !! values, IA(N+1)-1 of them
  real(dp), intent(in) :: f(n)             !! linear term F
  integer, intent(in) :: kind(n)           !! 0 free, 1 lower bound, 2 fixed
  real(dp), intent(in) :: bnd(n)           !! bound values (referenced where KIND /= 0)
  real(dp), intent(inout) :: x(n)          !! start on entry, solution on exit
  integer, intent(in) :: method            !! 1 projected SOR, 2 active set
  real(dp), intent(in) :: omega            !! SOR relaxation in (0, 2) (METHOD 1)
  real(dp), intent(in) :: tol              !! tolerance on RES, 0 < TOL < 1
  integer, intent(in) :: maxit             !! iteration limit (>= 1)
  integer, intent(out) :: iter             !! iterations done
  real(dp), intent(out) :: res             !! relative KKT residual of X
  integer, intent(out) :: info             !! status, see above

  !> Largest |A(i,j) - A(j,i)| accepted, relative to max |A(i,j)| (rounding of an assembly).
  real(dp), parameter :: symmetry_rel_tol = 1.0e-12_dp
  type(csr_t) :: mat
  type(psor_settings_t) :: pset
  type(psor_result_t) :: pres
  type(active_set_settings_t) :: aset
  type(active_set_result_t) :: ares
  type(status_t) :: st
  integer, allocatable :: rp(:), ci(:)
  real(dp), allocatable :: v(:)
  integer :: i, p, nnz

  info = 0
  iter = 0
  res = 0.0_dp
  ! ---- arguments, in order
  if (n < 1) then
    info = -1
    return
  end if
  if (ia(1) /= 1) then
    info = -2
    return
  end if
  do i = 1, n
    if (ia(i + 1) < ia(i)) then
      info = -2
      return
    end if
  end do
  nnz = ia(n + 1) - 1
  do p = 1, nnz
    if (ja(p) < 1 .or. ja(p) > n) then
      info = -3
      return
    end if
  end do
  ! sorted copy: two counting-sort transposes order the columns of every row
  call transpose_csr(ia, ja(1:nnz), a(1:nnz), rp, ci, v)
  call transpose_csr(rp, ci, v, mat%rowptr, mat%col, mat%val)
  mat%n = n
  allocate (mat%diag(n), source=0)
  do i = 1, n
    do p = mat%rowptr(i), mat%rowptr(i + 1) - 1
      if (p > mat%rowptr(i)) then
        if (mat%col(p) == mat%col(p - 1)) then
          info = -3                         ! duplicate entry (i, col)
          return
        end if
      end if
      if (mat%col(p) == i) mat%diag(i) = p
    end do
  end do
  if (.not. all(ieee_is_finite(mat%val))) then
    info = -4
    return
  end if
  if (any(mat%diag == 0)) then
    info = -4                               ! a diagonal entry is missing
    return
  end if
  if (any(mat%val(mat%diag) <= 0.0_dp) .or. .not. csr_is_symmetric(mat, symmetry_rel_tol)) then
    info = -4
    return
  end if
  if (.not. all(ieee_is_finite(f))) then
    info = -5
    return
  end if
  if (any(kind < 0 .or. kind > 2)) then
    info = -6
    return
  end if
  do i = 1, n
    if (kind(i) /= BOUND_FREE .and. .not. ieee_is_finite(bnd(i))) then
      info = -7
      return
    end if
  end do
  if (.not. all(ieee_is_finite(x))) then
    info = -8
    return
  end if
  if (method /= 1 .and. method /= 2) then
    info = -9
    return
  end if
  if (method == 1 .and. .not. (omega > 0.0_dp .and. omega < 2.0_dp)) then
    info = -10
    return
  end if
  if (.not. (tol > 0.0_dp .and. tol < 1.0_dp)) then
    info = -11
    return
  end if
  if (maxit < 1) then
    info = -12
    return
  end if

  ! ---- solve
  if (method == 1) then
    pset%omega = omega
    pset%tol = tol
    pset%max_iter = maxit
    call psor_solve(mat, f, kind, bnd, x, pset, pres, st)
    iter = pres%iterations
    res = pres%kkt_residual
  else
    aset%max_iter = maxit
    aset%fallback_tol = tol
    call active_set_solve(mat, f, kind, bnd, x, aset, ares, st)
    iter = ares%iterations
    res = ares%kkt_residual
  end if
  if (.not. is_ok(st)) then
    info = 2
    return
  end if
  where (kind == BOUND_FIXED) x = bnd
  if (res > tol) info = 1

contains

  !> The transpose (CSC of the input = CSR of A^T) by a counting sort: the entries of each
  !> output row come in increasing input-row order.  Applied twice, it sorts the columns.
  subroutine transpose_csr(rp_in, ci_in, v_in, rp_out, ci_out, v_out)
    integer, intent(in) :: rp_in(:), ci_in(:)
    real(dp), intent(in) :: v_in(:)
    integer, allocatable, intent(out) :: rp_out(:), ci_out(:)
    real(dp), allocatable, intent(out) :: v_out(:)
    integer :: r, q, c, m
    m = size(rp_in) - 1
    allocate (rp_out(m + 1), source=0)
    allocate (ci_out(size(ci_in)), v_out(size(ci_in)))
    do q = 1, size(ci_in)
      rp_out(ci_in(q) + 1) = rp_out(ci_in(q) + 1) + 1
    end do
    rp_out(1) = 1
    do r = 1, m
      rp_out(r + 1) = rp_out(r + 1) + rp_out(r)
    end do
    do r = 1, m
      do q = rp_in(r), rp_in(r + 1) - 1
        c = ci_in(q)
        ci_out(rp_out(c)) = r
        v_out(rp_out(c)) = v_in(q)
        rp_out(c) = rp_out(c) + 1
      end do
    end do
    ! rp_out(c) now points one past row c: shift back
    do r = m, 1, -1
      rp_out(r + 1) = rp_out(r)
    end do
    rp_out(1) = 1
  end subroutine transpose_csr
end subroutine dsbqp

!> DSSIGN: the primal and dual analysis of problem IPROB on the caller's mesh, one level
!> (no refinement), as dualsig_driver's run_one does for one level:
!>   IPROB 1 (P1): -Lap u + u = f, Signorini conditions on all of Gamma;
!>   IPROB 2 (P2): -Lap u = f, u = 0 on Gamma_u (IBMARK 1), Signorini on Gamma_a (IBMARK 2).
!> Mesh: XY(2,NNODE) node coordinates; ITRI(3,NTRI) vertex numbers, either orientation
!> (clockwise triangles are used with vertices 2 and 3 swapped, as the mesh reader does;
!> Q is still returned in the caller's vertex order); IBEDGE(2,NBEDGE) the boundary sides,
!> either orientation, each once, ALL of them (for IPROB 1, NBEDGE = 0 lets DSSIGN find
!> them); IBMARK(NBEDGE) 1 = Gamma_u, 2 = Gamma_a (IPROB 1: only 2).
!> FSRC: EXTERNAL DOUBLE PRECISION FUNCTION FSRC(X, Y), the source f; it is evaluated at
!> quadrature points and, for the P2 dual, on the mesh's bounding box (lambda_bar is an
!> integral of f along x from the leftmost abscissa), so it must be defined there.
!> IOPT(10), ROPT(10): options, 0 = default in every slot (see the README, "F77 interface").
!> Outputs: U(NNODE) the primal solution u_h at the nodes (on entry the start when
!> IOPT(9) = 1); Q(6,NTRI) the dual field at the vertices of each triangle, (Q(1,t), Q(2,t))
!> at vertex 1, (3:4) at vertex 2, (5:6) at vertex 3: P1 the continuous q, P2 the
!> equilibrium field lambda_h (discontinuous); BOUNDS(4) = (E, energy_lo, energy_hi, 0):
!> the a posteriori bound E >= ||u - u_h||^2 in the energy norm (P1 (6.13): full H1 norm;
!> P2 (6.26): H1 seminorm) and energy_lo <= (f, u) <= energy_hi ((6.14), Theorem 6.4).
!> INFO: 0 success; > 0 a sum of 1 (the primal solver stopped at its iteration limit),
!> 2 (the dual solver stopped at its limit) and 4 (P2: the dual field's divergence defect
!> exceeds ROPT(7): E and energy_hi are not guaranteed), or 8 alone (a computation failed:
!> factorisation, non-finite values, unsupported geometry; Q and BOUNDS are zero);
!> -k argument k is invalid (U is then unchanged, Q and BOUNDS are zero).
subroutine dssign(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, iopt, ropt, u, q, bounds, info)
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp, geom_rel_tol
  use dualsig_fields, only: scalar_field, function_field_t, function_field
  use dualsig_mesh, only: mesh_t, mesh_build_topology, mesh_triangle_area, mesh_h, mesh_diameter
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_sparse_direct, only: ORDERING_BEST, ORDERING_AMD, ORDERING_METIS, ORDERING_NATURAL, ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: geometric_ordering
  use dualsig_problem_primal, only: primal_system_t, primal_constraints, primal_assemble
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_solve
  use dualsig_estimate_dual_p1, only: dual_p1_bounds_t, dual_p1_bounds
  use dualsig_problem_dual_p2, only: dual_p2_settings_t, dual_p2_result_t, dual_p2_field_t, dual_p2_solve, &
                                     dual_p2_lambda, dual_p2_check_assumptions
  use dualsig_estimate_dual_p2, only: dual_p2_bounds_t, dual_p2_bounds
  use dualsig_status, only: status_t, is_ok, DS_OK
  use dualsig_strings, only: itoa, rtoa
  implicit none
  integer, intent(in) :: iprob                 !! 1 (P1) or 2 (P2)
  integer, intent(in) :: nnode                 !! number of nodes (>= 3)
  real(dp), intent(in) :: xy(2, nnode)         !! node coordinates
  integer, intent(in) :: ntri                  !! number of triangles (>= 1)
  integer, intent(in) :: itri(3, ntri)         !! vertices of each triangle
  integer, intent(in) :: nbedge                !! number of listed boundary sides (>= 0)
  integer, intent(in) :: ibedge(2, nbedge)     !! end nodes of each boundary side
  integer, intent(in) :: ibmark(nbedge)        !! 1 = Gamma_u, 2 = Gamma_a
  procedure(scalar_field) :: fsrc              !! source f(x, y)
  integer, intent(in) :: iopt(10)              !! integer options (0 = default)
  real(dp), intent(in) :: ropt(10)             !! real options (0 = default)
  real(dp), intent(inout) :: u(nnode)          !! primal solution (start if IOPT(9) = 1)
  real(dp), intent(out) :: q(6, ntri)          !! dual field at the vertices
  real(dp), intent(out) :: bounds(4)           !! E, energy_lo, energy_hi, reserved (0)
  integer, intent(out) :: info                 !! status, see above

  ! Defaults of the option slots (the driver's defaults, dualsig_io_config).
  integer, parameter :: default_primal_method = 2         !! IOPT(1): active set
  integer, parameter :: default_max_iter = 200000         !! IOPT(2)
  integer, parameter :: default_dual_max_iter = 20000     !! IOPT(7)
  integer, parameter :: default_check_every = 10          !! IOPT(8)
  real(dp), parameter :: default_tol = 1.0e-10_dp         !! ROPT(1)
  real(dp), parameter :: default_omega = 1.0_dp           !! ROPT(2)
  real(dp), parameter :: default_dual_tol = 1.0e-10_dp    !! ROPT(3)
  real(dp), parameter :: default_dual_tol_h2 = 1.0e-4_dp  !! ROPT(4)
  real(dp), parameter :: default_admissible = 1.0e-10_dp  !! ROPT(7), as dualsig_driver
  integer, parameter :: dual_off = 3                      !! IOPT(3) value: no dual analysis
  ! Quadrature degrees, as in dualsig_driver.
  integer, parameter :: load_degree = 5
  integer, parameter :: bound_degree_p1 = 16
  integer, parameter :: bound_degree_p2 = 12
  ! Boundary markers of IBMARK.
  integer, parameter :: mark_gamma_u = 1, mark_gamma_a = 2
  ! INFO values > 0.
  integer, parameter :: info_primal_limit = 1, info_dual_limit = 2, info_not_admissible = 4, &
                        info_failed = 8

  integer :: verbosity, out, primal_method, max_iter, dual_method, ordering, dual_max_iter, check_every
  real(dp) :: tol, omega, dual_tol, dual_tol_h2, rho, penalty, admissible, h
  type(mesh_t) :: mesh
  logical, allocatable :: flipped(:), is_gamma_a(:)
  ! sides of the triangulation, bucketed by their smaller node (see build_sides)
  integer, allocatable :: head(:), fill(:), side_hi(:), side_count(:), side_from(:,:)
  logical, allocatable :: listed(:)
  type(primal_system_t) :: sys
  type(tri_rule_t) :: load_rule
  type(status_t) :: st
  integer :: i, j, t, p, a, b, lo, nbside, nu, na
  real(dp) :: area_tol
  type(function_field_t) :: f                  !! the source fsrc as a field

  f = function_field(fsrc)
  info = 0
  bounds = 0.0_dp
  q = 0.0_dp
  verbosity = 0
  if (iopt(4) >= 0 .and. iopt(4) <= 2) verbosity = iopt(4)
  out = output_unit
  if (iopt(5) > 0) out = iopt(5)

  ! ---- scalar and array arguments, in order
  if (iprob /= PROBLEM_P1 .and. iprob /= PROBLEM_P2) then
    call fail(1, 'IPROB = ' // itoa(iprob) // ' (expected 1 or 2)')
    return
  end if
  if (nnode < 3) then
    call fail(2, 'NNODE = ' // itoa(nnode) // ' (expected >= 3)')
    return
  end if
  do i = 1, nnode
    if (.not. all(ieee_is_finite(xy(:, i)))) then
      call fail(3, 'XY(:,' // itoa(i) // ') is not finite')
      return
    end if
  end do
  if (ntri < 1) then
    call fail(4, 'NTRI = ' // itoa(ntri) // ' (expected >= 1)')
    return
  end if
  mesh%nnode = nnode
  mesh%ntri = ntri
  mesh%xy = xy
  mesh%tri = itri
  allocate (flipped(ntri), source=.false.)
  area_tol = geom_rel_tol * mesh_diameter(mesh)**2
  do t = 1, ntri
    if (any(itri(:, t) < 1 .or. itri(:, t) > nnode)) then
      call fail(5, 'triangle ' // itoa(t) // ' has a vertex index outside 1..' // itoa(nnode))
      return
    end if
    if (itri(1, t) == itri(2, t) .or. itri(2, t) == itri(3, t) .or. itri(3, t) == itri(1, t)) then
      call fail(5, 'triangle ' // itoa(t) // ' repeats a vertex')
      return
    end if
    if (abs(mesh_triangle_area(mesh, t)) <= area_tol) then
      call fail(5, 'triangle ' // itoa(t) // ' has zero area (collinear vertices)')
      return
    end if
    ! clockwise: swap vertices 2 and 3 (as dualsig_mesh_io); Q is mapped back below
    if (mesh_triangle_area(mesh, t) < 0.0_dp) then
      mesh%tri(2:3, t) = itri([3, 2], t)
      flipped(t) = .true.
    end if
  end do
  call build_sides()
  if (info /= 0) return
  if (nbedge < 0) then
    call fail(6, 'NBEDGE = ' // itoa(nbedge) // ' (expected >= 0)')
    return
  end if
  if (iprob == PROBLEM_P2 .and. nbedge == 0) then
    call fail(6, 'NBEDGE = 0: problem P2 needs the boundary sides and their markers')
    return
  end if
  ! IBEDGE: every listed side is a boundary side of the triangles, once; all are listed
  allocate (listed(size(side_hi)), source=.false.)
  do j = 1, nbedge
    a = ibedge(1, j)
    b = ibedge(2, j)
    if (min(a, b) < 1 .or. max(a, b) > nnode) then
      call fail(7, 'boundary side ' // itoa(j) // ' has a node index outside 1..' // itoa(nnode))
      return
    end if
    p = find_side(min(a, b), max(a, b))
    if (p == 0) then
      call fail(7, 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is not a side of any triangle')
      return
    end if
    if (side_count(p) /= 1) then
      call fail(7, 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is an interior side')
      return
    end if
    if (listed(p)) then
      call fail(7, 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is listed twice')
      return
    end if
    listed(p) = .true.
  end do
  if (nbedge > 0 .and. nbedge < nbside) then
    do lo = 1, nnode
      do p = head(lo), head(lo) + fill(lo) - 1
        if (side_count(p) == 1 .and. .not. listed(p)) then
          call fail(7, 'the boundary side (' // itoa(lo) // ',' // itoa(side_hi(p)) // ') is missing: all ' // &
            itoa(nbside) // ' boundary sides must be listed, found ' // itoa(nbedge))
          return
        end if
      end do
    end do
  end if
  ! IBMARK
  do j = 1, nbedge
    if (ibmark(j) /= mark_gamma_u .and. ibmark(j) /= mark_gamma_a) then
      call fail(8, 'IBMARK(' // itoa(j) // ') = ' // itoa(ibmark(j)) // ' (expected 1 = Gamma_u or 2 = Gamma_a)')
      return
    end if
    if (iprob == PROBLEM_P1 .and. ibmark(j) /= mark_gamma_a) then
      call fail(8, 'IBMARK(' // itoa(j) // ') = 1: problem P1 has Signorini conditions on all of Gamma (use 2)')
      return
    end if
  end do
  nu = count(ibmark(1:nbedge) == mark_gamma_u)
  if (iprob == PROBLEM_P2 .and. nu == 0) then
    call fail(8, 'no side has IBMARK = 1: problem P2 needs a non-empty Gamma_u')
    return
  end if
  ! FSRC at the nodes
  do i = 1, nnode
    if (.not. ieee_is_finite(fsrc(xy(1, i), xy(2, i)))) then
      call fail(9, 'FSRC is not finite at node ' // itoa(i))
      return
    end if
  end do
  call read_options()
  if (info /= 0) return
  if (iopt(9) == 1) then
    if (.not. all(ieee_is_finite(u))) then
      call fail(12, 'IOPT(9) = 1 but the start U is not finite')
      return
    end if
  end if

  ! ---- mesh topology
  if (nbedge > 0) then
    mesh%nbedge = nbedge
    mesh%bedge_nodes = ibedge
    mesh%bedge_marker = ibmark
  else
    ! P1 without a list: the sides of one triangle, oriented as in it (domain on the left)
    mesh%nbedge = nbside
    allocate (mesh%bedge_nodes(2, nbside), mesh%bedge_marker(nbside))
    j = 0
    do lo = 1, nnode
      do p = head(lo), head(lo) + fill(lo) - 1
        if (side_count(p) /= 1) cycle
        j = j + 1
        mesh%bedge_nodes(:, j) = side_from(:, p)
      end do
    end do
    mesh%bedge_marker = mark_gamma_a
  end if
  call mesh_build_topology(mesh, st)
  if (st%code /= DS_OK) then
    call fail(5, st%msg)
    return
  end if
  allocate (is_gamma_a(mesh%nbedge))
  is_gamma_a = mesh%bedge_marker == mark_gamma_a
  na = count(is_gamma_a)
  if (iprob == PROBLEM_P2 .and. dual_method /= dual_off) then
    call dual_p2_check_assumptions(mesh, is_gamma_a, st)
    if (st%code /= DS_OK) then
      call fail(8, st%msg)
      return
    end if
  end if

  ! ---- primal problem
  load_rule = tri_rule(load_degree)
  call primal_assemble(mesh, iprob, f, load_rule, sys)
  call primal_constraints(mesh, iprob, [merge(mark_gamma_u, 0, nu > 0)], [merge(mark_gamma_a, 0, na > 0)], &
                          sys%kind, sys%bnd, st)
  if (st%code /= DS_OK) then
    call fail(8, st%msg)
    return
  end if
  if (iopt(9) /= 1) u = 0.0_dp
  call solve_primal()
  if (info == info_failed) return
  if (verbosity >= 1) write (out, '(a,i0,a,i0,a,i0,a,i0,a)') 'DSSIGN: problem P', iprob, ', ', nnode, ' nodes, ', &
    ntri, ' triangles, ', count(flipped), ' clockwise triangles reoriented'

  ! ---- dual problem and bounds
  if (dual_method /= dual_off) then
    h = mesh_h(mesh)
    if (iprob == PROBLEM_P1) then
      call dual_p1()
    else
      call dual_p2()
    end if
    if (info == info_failed) then
      q = 0.0_dp
      bounds = 0.0_dp
      return
    end if
    if (verbosity >= 1) write (out, '(a,es15.8,a,es15.8,a,es15.8)') 'DSSIGN: E = ', bounds(1), &
      ', energy bounds ', bounds(2), ' <= (f,u) <= ', bounds(3)
  end if
  if (verbosity >= 1 .and. info > 0) write (out, '(a,i0)') 'DSSIGN: INFO = ', info

contains

  !> INFO = -k for argument k, with the message printed when IOPT(4) >= 1.
  subroutine fail(k, msg)
    integer, intent(in) :: k
    character(len=*), intent(in) :: msg
    info = -k
    if (verbosity >= 1) write (out, '(a,i0,a,i0,a)') 'DSSIGN: INFO = ', info, ' (argument ', k, '): ' // msg
  end subroutine fail

  !> A computation failed: INFO = 8, the message printed when IOPT(4) >= 1.
  subroutine failed(what, msg)
    character(len=*), intent(in) :: what, msg
    info = info_failed
    if (verbosity >= 1) write (out, '(a,i0,a)') 'DSSIGN: INFO = ', info, ': ' // what // ': ' // msg
  end subroutine failed

  !> The sides of the (reoriented) triangles: side p = (lo, side_hi(p)) lives in bucket lo,
  !> slots head(lo) .. head(lo)+fill(lo)-1; side_count(p) triangles share it (> 2 is an
  !> error of ITRI); side_from(:, p) is the side as it runs in its first triangle
  !> (counter-clockwise, so a boundary side has the domain on its left).  nbside counts the
  !> sides with one triangle.  Linear in NTRI (buckets hold a node's few neighbours).
  subroutine build_sides()
    integer :: tt, k, aa, bb, l, s
    allocate (head(nnode + 1), fill(nnode), source=0)
    do tt = 1, ntri
      do k = 1, 3
        l = min(mesh%tri(k, tt), mesh%tri(mod(k, 3) + 1, tt))
        head(l + 1) = head(l + 1) + 1
      end do
    end do
    head(1) = 1
    do l = 1, nnode
      head(l + 1) = head(l + 1) + head(l)
    end do
    allocate (side_hi(3 * ntri), side_count(3 * ntri), side_from(2, 3 * ntri), source=0)
    do tt = 1, ntri
      do k = 1, 3
        aa = mesh%tri(k, tt)
        bb = mesh%tri(mod(k, 3) + 1, tt)
        l = min(aa, bb)
        s = find_side(l, max(aa, bb))
        if (s == 0) then
          s = head(l) + fill(l)
          fill(l) = fill(l) + 1
          side_hi(s) = max(aa, bb)
          side_from(:, s) = [aa, bb]
        end if
        side_count(s) = side_count(s) + 1
        if (side_count(s) > 2) then
          call fail(5, 'the side (' // itoa(l) // ',' // itoa(max(aa, bb)) // &
            ') is shared by more than two triangles (third: ' // itoa(tt) // ')')
          return
        end if
      end do
    end do
    nbside = count(side_count == 1)
  end subroutine build_sides

  !> The slot of side (l, m), l < m, or 0 when no triangle has it.
  integer function find_side(l, m) result(s)
    integer, intent(in) :: l, m
    integer :: r
    s = 0
    do r = head(l), head(l) + fill(l) - 1
      if (side_hi(r) == m) then
        s = r
        return
      end if
    end do
  end function find_side

  !> Options: IOPT(1..10), ROPT(1..10), 0 = default in every slot; INFO = -10 / -11 for a
  !> value out of range (the slot is named in the message).
  subroutine read_options()
    integer :: k
    primal_method = merge(default_primal_method, iopt(1), iopt(1) == 0)
    max_iter = merge(default_max_iter, iopt(2), iopt(2) == 0)
    dual_method = iopt(3)
    ordering = iopt(6)
    dual_max_iter = merge(default_dual_max_iter, iopt(7), iopt(7) == 0)
    check_every = merge(default_check_every, iopt(8), iopt(8) == 0)
    if (primal_method < 1 .or. primal_method > 2) then
      call fail(10, 'IOPT(1) = ' // itoa(iopt(1)) // ' (primal solver: 0 default, 1 psor, 2 active set)')
    else if (max_iter < 1) then
      call fail(10, 'IOPT(2) = ' // itoa(iopt(2)) // ' (primal iteration limit: 0 default or >= 1)')
    else if (dual_method < 0 .or. dual_method > dual_off) then
      call fail(10, 'IOPT(3) = ' // itoa(iopt(3)) // ' (dual: 0/1 default method, 2 uzawa, 3 none)')
    else if (iopt(4) < 0 .or. iopt(4) > 2) then
      call fail(10, 'IOPT(4) = ' // itoa(iopt(4)) // ' (printing: 0, 1 or 2)')
    else if (iopt(5) < 0) then
      call fail(10, 'IOPT(5) = ' // itoa(iopt(5)) // ' (output unit: 0 default or > 0)')
    else if (ordering < 0 .or. ordering > 5) then
      call fail(10, 'IOPT(6) = ' // itoa(iopt(6)) // ' (ordering: 0/1 amd, 2 metis, 3 best, 4 natural, 5 nd)')
    else if (dual_max_iter < 1) then
      call fail(10, 'IOPT(7) = ' // itoa(iopt(7)) // ' (dual iteration limit: 0 default or >= 1)')
    else if (check_every < 1) then
      call fail(10, 'IOPT(8) = ' // itoa(iopt(8)) // ' (sweeps between residuals: 0 default or >= 1)')
    else if (iopt(9) < 0 .or. iopt(9) > 1) then
      call fail(10, 'IOPT(9) = ' // itoa(iopt(9)) // ' (start: 0 zero, 1 U on entry)')
    else if (iopt(10) /= 0) then
      call fail(10, 'IOPT(10) = ' // itoa(iopt(10)) // ' (reserved: must be 0)')
    end if
    if (info /= 0) return
    select case (ordering)
    case (2)
      ordering = ORDERING_METIS
    case (3)
      ordering = ORDERING_BEST
    case (4)
      ordering = ORDERING_NATURAL
    case (5)
      ordering = ORDERING_GEOMETRIC
    case default
      ordering = ORDERING_AMD
    end select

    do k = 1, 10
      if (.not. ieee_is_finite(ropt(k))) then
        call fail(11, 'ROPT(' // itoa(k) // ') is not finite')
        return
      end if
    end do
    tol = merge(default_tol, ropt(1), ropt(1) == 0.0_dp)
    omega = merge(default_omega, ropt(2), ropt(2) == 0.0_dp)
    dual_tol = merge(default_dual_tol, ropt(3), ropt(3) == 0.0_dp)
    dual_tol_h2 = merge(default_dual_tol_h2, ropt(4), ropt(4) == 0.0_dp)
    rho = ropt(5)
    penalty = ropt(6)
    admissible = merge(default_admissible, ropt(7), ropt(7) == 0.0_dp)
    if (.not. (tol > 0.0_dp .and. tol < 1.0_dp)) then
      call fail(11, 'ROPT(1) = ' // rtoa(ropt(1)) // ' (primal tolerance: 0 default or in (0, 1))')
    else if (.not. (omega > 0.0_dp .and. omega < 2.0_dp)) then
      call fail(11, 'ROPT(2) = ' // rtoa(ropt(2)) // ' (SOR omega: 0 default or in (0, 2))')
    else if (.not. (dual_tol > 0.0_dp .and. dual_tol < 1.0_dp)) then
      call fail(11, 'ROPT(3) = ' // rtoa(ropt(3)) // ' (dual tolerance: 0 default or in (0, 1))')
    else if (dual_tol_h2 < 0.0_dp) then
      call fail(11, 'ROPT(4) = ' // rtoa(ropt(4)) // ' (dual tol_h2: 0 default or > 0)')
    else if (rho < 0.0_dp) then
      call fail(11, 'ROPT(5) = ' // rtoa(ropt(5)) // ' (Uzawa step: 0 automatic or > 0)')
    else if (penalty < 0.0_dp) then
      call fail(11, 'ROPT(6) = ' // rtoa(ropt(6)) // ' (augmented Lagrangian penalty: 0 automatic or > 0)')
    else if (admissible < 0.0_dp) then
      call fail(11, 'ROPT(7) = ' // rtoa(ropt(7)) // ' (admissible divergence defect: 0 default or > 0)')
    else if (any(ropt(8:10) /= 0.0_dp)) then
      call fail(11, 'ROPT(8:10) are reserved: must be 0')
    end if
  end subroutine read_options

  !> The primal QP by projected SOR or the active-set method, from U (zero or the caller's).
  subroutine solve_primal()
    type(psor_settings_t) :: pset
    type(psor_result_t) :: pres
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    type(status_t) :: st_solve
    integer :: iters
    real(dp) :: kkt
    if (primal_method == 2) then
      aset%max_iter = max_iter
      aset%ordering = ordering
      if (ordering == ORDERING_GEOMETRIC) then
        ! nested dissection from the node coordinates (from 1e4 unknowns), AMD below
        call geometric_ordering(mesh%xy, sys%a, aset%ordering, aset%perm, st_solve)
      end if
      call active_set_solve(sys%a, sys%load, sys%kind, sys%bnd, u, aset, ares, st_solve)
      iters = ares%iterations
      kkt = ares%kkt_residual
    else
      pset%omega = omega
      pset%tol = tol
      pset%max_iter = max_iter
      pset%check_every = check_every
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, pset, pres, st_solve)
      iters = pres%iterations
      kkt = pres%kkt_residual
    end if
    if (.not. is_ok(st_solve)) then
      call failed('primal solve', st_solve%msg)
      return
    end if
    if (st_solve%code /= DS_OK) info = info + info_primal_limit
    if (verbosity >= 2) write (out, '(a,a,a,i0,a,es9.2)') 'DSSIGN: primal ', &
      trim(merge('active set', 'psor      ', primal_method == 2)), ': ', iters, ' iterations, KKT residual ', kkt
    if (verbosity >= 1 .and. st_solve%code /= DS_OK) write (out, '(a)') 'DSSIGN: warning: ' // st_solve%msg
  end subroutine solve_primal

  !> P1: the feasible continuous field q (dual_p1_solve, warm-started from u by
  !> complementarity) and the bounds (6.13), (6.14).
  subroutine dual_p1()
    type(dual_p1_settings_t) :: dset
    type(dual_p1_result_t) :: dres
    type(dual_p1_bounds_t) :: b1
    type(tri_rule_t) :: bound_rule
    real(dp), allocatable :: qv(:)
    type(status_t) :: st_dual
    integer :: tt, k, node
    dset%method = trim(merge('uzawa     ', 'active_set', dual_method == 2))
    dset%rho = rho
    dset%max_iter = dual_max_iter
    dset%ordering = ordering
    ! Uzawa tolerance tied to the discretisation, as in the driver
    dset%tol = max(dual_tol, dual_tol_h2 * (h / mesh_diameter(mesh))**2)
    call dual_p1_solve(mesh, f, load_rule, dset, qv, dres, st_dual, u_primal=u)
    if (.not. is_ok(st_dual)) then
      call failed('dual P1 solve', st_dual%msg)
      return
    end if
    if (st_dual%code /= DS_OK) then
      info = info + info_dual_limit
      if (verbosity >= 1) write (out, '(a)') 'DSSIGN: warning: ' // st_dual%msg
    end if
    if (verbosity >= 2) write (out, '(a,a,a,i0,a,es9.2,a,i0,a,i0)') 'DSSIGN: dual ', trim(dset%method), ': ', &
      dres%iterations, ' iterations, residual ', dres%residual, ', constraints ', dres%nconstraints, &
      ', active ', dres%nactive
    bound_rule = tri_rule(bound_degree_p1)
    call dual_p1_bounds(mesh, u, qv, f, bound_rule, b1)
    bounds(1:3) = [b1%est, b1%energy_lo, b1%energy_hi]
    do tt = 1, ntri
      do k = 1, 3
        node = itri(k, tt)
        q(2 * k - 1:2 * k, tt) = qv(2 * node - 1:2 * node)
      end do
    end do
  end subroutine dual_p1

  !> P2: the equilibrium field lambda_h = lambda_f + q_h (dual_p2_solve, warm-started from
  !> u), the bounds (6.26) and Theorem 6.4, and lambda_h at the vertices.
  subroutine dual_p2()
    type(dual_p2_settings_t) :: dset
    type(dual_p2_result_t) :: dres
    type(dual_p2_field_t) :: field
    type(dual_p2_bounds_t) :: b2
    type(tri_rule_t) :: bound_rule
    type(status_t) :: st_dual
    real(dp) :: bary(3)
    integer :: tt, k, kin
    dset%method = trim(merge('uzawa    ', 'augmented', dual_method == 2))
    dset%rho = rho
    dset%max_iter = dual_max_iter
    dset%ordering = ordering
    dset%penalty = penalty
    dset%tol = max(dual_tol, dual_tol_h2 * (h / mesh_diameter(mesh))**2)
    call dual_p2_solve(mesh, f, is_gamma_a, minval(mesh%xy(1, :)), dset, field, dres, st_dual, u_primal=u)
    if (.not. is_ok(st_dual)) then
      call failed('dual P2 solve', st_dual%msg)
      return
    end if
    if (st_dual%code /= DS_OK) then
      info = info + info_dual_limit
      if (verbosity >= 1) write (out, '(a)') 'DSSIGN: warning: ' // st_dual%msg
    end if
    if (dres%defect > admissible) then
      info = info + info_not_admissible
      if (verbosity >= 1) write (out, '(a,es9.2,a)') 'DSSIGN: warning: the dual field has a divergence defect ', &
        dres%defect, ' (relative): lambda_h is not admissible, E and energy_hi are NOT guaranteed bounds'
    end if
    if (verbosity >= 2) write (out, '(a,a,a,i0,a,es9.2,a,i0,a,i0)') 'DSSIGN: dual ', trim(dset%method), ': ', &
      dres%iterations, ' iterations, divergence defect ', dres%defect, ', constraints ', dres%nconstraints, &
      ', active ', dres%nactive
    bound_rule = tri_rule(bound_degree_p2)
    call dual_p2_bounds(mesh, u, field, f, is_gamma_a, bound_rule, b2)
    bounds(1:3) = [b2%est, b2%energy_lo, b2%energy_hi]
    do tt = 1, ntri
      do k = 1, 3
        ! the caller's vertex k is vertex kin of the (possibly reoriented) triangle
        kin = k
        if (flipped(tt) .and. k > 1) kin = 5 - k
        bary = 0.0_dp
        bary(kin) = 1.0_dp
        q(2 * k - 1:2 * k, tt) = dual_p2_lambda(field, mesh, f, tt, bary)
      end do
    end do
  end subroutine dual_p2
end subroutine dssign
