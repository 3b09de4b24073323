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
!>       iterate); 2 numerical failure (A not positive definite: a Lanczos estimate of the
!>       smallest eigenvalue of D^(-1/2) A D^(-1/2) is negative, checked before the solve, or
!>       the Cholesky factorisation failed or the iterate became non-finite; X is not a
!>       solution; or out of memory);
!>       -k argument k is invalid (k = 1..12, positions as in the argument list).
subroutine dsbqp(n, ia, ja, a, f, kind, bnd, x, method, omega, tol, maxit, iter, res, info)
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t, csr_is_symmetric
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_qp_types, only: BOUND_FREE, BOUND_FIXED
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_status, only: status_t, is_ok
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  use dualsig_f77_adapter, only: f77_transpose_csr, f77_no_negative_curvature
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
  integer :: i, p, nnz, ist

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
  call f77_transpose_csr(ia, ja(1:nnz), a(1:nnz), rp, ci, v, st)
  if (is_ok(st)) call f77_transpose_csr(rp, ci, v, mat%rowptr, mat%col, mat%val, st)
  mat%n = n
  if (is_ok(st)) then
    allocate (mat%diag(n), stat=ist)
    if (.not. alloc_failed(ist, st, 'the diagonal positions', n, BYTES_INT)) mat%diag = 0
  end if
  if (.not. is_ok(st)) then
    info = 2                                ! out of memory
    return
  end if
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

  ! ---- A positive definite, as far as a few Lanczos steps can refute it: a KKT point of an
  ! indefinite A need not be its minimiser (INFO 0 was returned at such a point)
  if (.not. f77_no_negative_curvature(mat)) then
    info = 2
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
  ! huge A and F can overflow to a non-finite iterate or residual: a numerical failure
  if (.not. (ieee_is_finite(res) .and. all(ieee_is_finite(x)))) then
    info = 2
    return
  end if
  where (kind == BOUND_FIXED) x = bnd
  if (res > tol) info = 1

end subroutine dsbqp

!> DSSIGN: the primal and dual analysis of problem IPROB on the caller's mesh, one level
!> (no refinement) of the analysis pipeline (dualsig_analysis), as the driver runs it:
!>   IPROB 1 (P1): -Lap u + u = f, Signorini conditions on all of Gamma;
!>   IPROB 2 (P2): -Lap u = f, u = 0 on Gamma_u (IBMARK 1), Signorini on Gamma_a (IBMARK 2).
!> Mesh: XY(2,NNODE) node coordinates; ITRI(3,NTRI) vertex numbers, all counter-clockwise
!> or all clockwise (then all are used with vertices 2 and 3 swapped, as the mesh readers
!> do; Q is still returned in the caller's vertex order; a mix is a folded mesh, INFO = -5,
!> as are duplicate triangles, several pieces and overlapping triangles); IBEDGE(2,NBEDGE) the boundary sides,
!> either orientation, each once, ALL of them (for IPROB 1, NBEDGE = 0 lets DSSIGN find
!> them); IBMARK(NBEDGE) 1 = Gamma_u, 2 = Gamma_a (IPROB 1: only 2).
!> FSRC: EXTERNAL DOUBLE PRECISION FUNCTION FSRC(X, Y), the source f; it is evaluated at
!> quadrature points and, for the P2 dual, on the mesh's bounding box (lambda_bar is an
!> integral of f along x from the leftmost abscissa), so it must be defined there.
!> IOPT(10), ROPT(10): options, 0 = default in every slot (see doc/library.md, "DSSIGN").
!> Outputs: U(NNODE) the primal solution u_h at the nodes (on entry the start when
!> IOPT(9) = 1); Q(6,NTRI) the dual field at the vertices of each triangle, (Q(1,t), Q(2,t))
!> at vertex 1, (3:4) at vertex 2, (5:6) at vertex 3: P1 the RT1 field q_h (IOPT(10) = 0
!> or 1; discontinuous, its normal component continuous) or the paper's continuous q
!> (IOPT(10) = 2), P2 the equilibrium field lambda_h (discontinuous);
!> BOUNDS(4) = (E, energy_lo, energy_hi, oscillation):
!> the a posteriori bound E >= ||u - u_h||^2 in the energy norm (P1 (6.13): full H1 norm;
!> P2 (6.26): H1 seminorm) and energy_lo <= (f, u) <= energy_hi ((6.14), Theorem 6.4).
!> INFO: 0 success; > 0 a sum of 1 (the primal solver stopped at its iteration limit),
!> 2 (the dual solver stopped at its limit) and 4 (P2: the dual field's divergence defect
!> exceeds ROPT(7): E and energy_hi are not guaranteed), or 8 alone (a computation failed:
!> factorisation, non-finite values, unsupported geometry; Q and BOUNDS are zero);
!> -k argument k is invalid (U is then unchanged, Q and BOUNDS are zero).
subroutine dssign(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, iopt, ropt, u, q, bounds, info)
  use dualsig_kinds, only: dp
  use dualsig_fields, only: scalar_field
  use dualsig_f77_adapter, only: dssign_run
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
  call dssign_run(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, iopt, ropt, u, q, bounds, info)
end subroutine dssign

!> DSSIGNB: DSSIGN for a source with known break lines: NBREAK (0 <= NBREAK <= 16) vertical
!> lines x = XBREAK(k) along which FSRC may jump or have a kink.  The integrals of f are
!> split there, so that a piecewise smooth f is integrated to full accuracy and the bounds
!> are certified (with DSSIGN, the integrals of such an f do not converge across the break
!> and INFO has the bit 4).  Arguments as DSSIGN; NBREAK is argument 10, XBREAK 11, and the
!> later arguments are numbered 12 (IOPT) to 18 (INFO) in INFO = -k.
subroutine dssignb(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, nbreak, xbreak, iopt, ropt, u, q, &
                   bounds, info)
  use dualsig_kinds, only: dp
  use dualsig_fields, only: scalar_field
  use dualsig_f77_adapter, only: dssign_run
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
  integer, intent(in) :: nbreak                !! number of break lines (0..16)
  real(dp), intent(in) :: xbreak(*)            !! their abscissae, NBREAK of them
  integer, intent(in) :: iopt(10)              !! integer options (0 = default)
  real(dp), intent(in) :: ropt(10)             !! real options (0 = default)
  real(dp), intent(inout) :: u(nnode)          !! primal solution (start if IOPT(9) = 1)
  real(dp), intent(out) :: q(6, ntri)          !! dual field at the vertices
  real(dp), intent(out) :: bounds(4)           !! E, energy_lo, energy_hi, oscillation part of E
  integer, intent(out) :: info                 !! status, see DSSIGN
  call dssign_run(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, iopt, ropt, u, q, bounds, info, &
                  nbreak, xbreak)
end subroutine dssignb
