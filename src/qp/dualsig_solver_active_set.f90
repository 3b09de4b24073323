!> Primal-dual active-set method (semismooth Newton) with a sparse Cholesky factorisation
!> for the bound-constrained QP
!>
!>     minimise 1/2 x^T A x - F^T x  subject to  x_i free / x_i >= bnd_i / x_i = bnd_i
!>
!> (the same kinds as dualsig_solver_psor).  With g = A x - F, a bounded unknown is
!> predicted active when g_i - A_ii (x_i - bnd_i) > 0; the active and the fixed unknowns
!> are held at their bound and the others solve the reduced system M(F) x = r, where M(F)
!> keeps the pattern of A with identity rows/columns for the held set F.
!>
!> Factorise once, correct small changes.  The factor of M(F1) is kept (optionally across
!> calls, in a workspace).  When the next set F differs from F1 in k <= max_lowrank
!> unknowns D, M(F) shares the block A_RR (R = the others) with M(F1), and
!>     A_RR^{-1} b_R = [y - Z C1^{-1} y(D)]_R,   y = M(F1)^{-1} [b_R; 0],
!>     Z = M(F1)^{-1} E_D,  C1 = Z(D, :)                                  (capacitance)
!>     x_D = S^{-1} (b_D - B^T A_RR^{-1} b_R),  S = M(F)_DD - B^T A_RR^{-1} B,
!>     x_R = A_RR^{-1} (b_R - B x_D),          B = M(F)_RD                 (bordering)
!> The columns that depend only on the kept factor and on one changed unknown d,
!>     z_d = M(F1)^{-1} e_d   and   y_d = M(F1)^{-1} u_d,  u_d = A(:, d) without the rows of F1,
!> are cached in the workspace, so that B's columns follow as y_d - Z u_d(D) and A_RR^{-1}
!> of them by the capacitance correction: an iteration costs ONE solve with the kept factor
!> plus one block solve (2 right-hand sides per unknown) for the unknowns not seen before
!> since the last factorisation, instead of a refactorisation.  The choice is made by a
!> cost model of the kept factor, never by the clock, so that a run's results do not depend
!> on the load of the machine (the two routes agree only to rounding): bordering is used
!> while its predicted cost, in single solves, is below that of a numeric refactorisation
!> (refactor_solves, from CHOLMOD's flop count and the factor's nonzeros; the symbolic
!> analysis is reused), and never for k > max_lowrank.
!>
!> Termination and safeguards: the method stops when the predicted set repeats (the KKT
!> conditions then hold to the accuracy of the solve).  A set seen before (a cycle) or the
!> iteration limit switches to projected SOR from the current projected iterate, which
!> converges for every SPD matrix; the result is reported with its KKT residual.  The
!> returned x is always projected on the bounds, hence feasible.
module dualsig_solver_active_set
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, csr_matvec
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_refactor, cholesky_solve, &
                                   cholesky_free, ORDERING_AMD
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_qp_types, only: BOUND_LOWER, BOUND_FIXED, kkt_residual
  use dualsig_status, only: status_t, set_warning, set_error, set_alloc_error, is_ok, DS_WARN_NOT_CONVERGED, DS_ERR_LAPACK
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL, BYTES_INT
  implicit none
  private

  public :: active_set_settings_t, active_set_result_t, active_set_solve, active_set_workspace_t, &
            active_set_workspace_free, refactor_solves

  type :: active_set_settings_t
    integer :: max_iter = 100            !! maximum number of active-set changes
    integer :: ordering = ORDERING_AMD   !! fill-reducing ordering (dualsig_sparse_direct)
    integer, allocatable :: perm(:)      !! the elimination order when ordering = ORDERING_GIVEN
    integer :: max_lowrank = 24          !! largest change handled by bordering (0: always refactorise)
    logical :: lowrank_by_cost = .true.  !! choose bordering by the cost model (.false.: whenever k <= max_lowrank)
    real(dp) :: fallback_tol = 1.0e-10_dp    !! KKT tolerance of the projected-SOR fallback
    integer :: fallback_max_iter = 1000000   !! sweeps of the fallback
    !> largest normwise backward error ||M x - b||_inf / (||M||_inf ||x||_inf + ||b||_inf) of a
    !> bordered solve; a larger one is discarded and the matrix refactorised
    real(dp) :: bordered_tol = 1.0e-12_dp    !! (seen: 1e-17..5e-15 when sound, ~2e-9 on the penalised L-shape matrix)
    logical :: fallback = .true.         !! .false.: no projected-SOR fallback (e.g. for a badly conditioned
                                         !! penalised matrix); a cycle or the limit is then only reported
  end type active_set_settings_t

  type :: active_set_result_t
    integer :: iterations = 0            !! active sets tried (solves)
    integer :: factorisations = 0        !! (re)factorisations (0 when a kept factor fitted)
    integer :: lowrank_solves = 0        !! iterations done by bordering on the kept factor
    real(dp) :: kkt_residual = 0.0_dp    !! relative KKT residual of the returned x
    logical :: converged = .false.       !! the active set was reproduced (or the fallback converged)
    logical :: fallback = .false.        !! projected SOR was needed (cycle or limit)
    integer :: nactive = 0               !! bounded unknowns at their bound
    integer(i8) :: nnz_factor = 0        !! nonzeros of the Cholesky factor
    character(len=8) :: ordering = ''    !! ordering used by CHOLMOD
  end type active_set_result_t

  !> State kept between calls for the SAME matrix (e.g. the outer steps of an augmented
  !> Lagrangian, where only the right-hand side changes): the factor of the reduced matrix
  !> and the held set it belongs to.  Free with active_set_workspace_free.
  type :: active_set_workspace_t
    logical :: have_factor = .false.
    type(cholesky_t) :: chol
    type(csr_t) :: ar                          !! the reduced matrix of `fixed`
    logical, allocatable :: fixed(:)
    ! bordering cache (valid for the kept factor): z_d and y_d of the unknowns idx(1:ncache)
    integer :: ncache = 0
    integer, allocatable :: cache_idx(:)
    logical, allocatable :: cache_has_y(:)     !! y_d computed (only needed for some d)
    real(dp), allocatable :: cache_z(:,:), cache_y(:,:)
    ! the last plain solve of this call, M1 base_sol = base_rhs (same F as the factor, same F):
    ! a bordered step derives M1^{-1} b_R from it without a solve
    logical :: base_valid = .false.
    real(dp), allocatable :: base_rhs(:), base_sol(:)
  end type active_set_workspace_t

  !> Sets remembered for cycle detection.
  integer, parameter :: history_len = 64
  !> Cost of one more right-hand side in a block solve, relative to a single solve
  !> (measured with CHOLMOD + OpenBLAS at 1e6 unknowns: 16 right-hand sides cost 6.8
  !> single solves).
  real(dp), parameter :: multi_rhs_cost = 0.4_dp
  !> The cost model of refactor_solves: a numeric refactorisation costs
  !> max(refactor_solves_min, fl / (4 nnz(L)) / refactor_speedup) single solves, fl being
  !> CHOLMOD's flop count of the factorisation and 4 nnz(L) the flops of a solve; the
  !> factorisation runs refactor_speedup times more flops a second (dense blocks) than the
  !> memory-bound solve, and below refactor_solves_min solves its fixed costs dominate.
  !> Measured (CHOLMOD supernodal + OpenBLAS, one thread, cold p2_contact meshes of 129^2 to
  !> 1025^2 nodes): refactorisation / solve time 30, 16.5 and 18 at fl / (4 nnz(L)) = 17,
  !> 49 and 85.
  real(dp), parameter :: refactor_speedup = 4.7_dp
  real(dp), parameter :: refactor_solves_min = 16.0_dp

  !> State of one active_set_solve call carried from step to step.
  type :: active_set_run_t
    integer :: nhist = 0                 !! sets remembered in hist
    integer(i8) :: hist(3, history_len)  !! hashes of the sets tried (ring, for cycle detection)
  end type active_set_run_t

contains

  !> Release the factor kept in a workspace.
  subroutine active_set_workspace_free(ws)
    type(active_set_workspace_t), intent(inout) :: ws
    call cholesky_free(ws%chol)
    ws%have_factor = .false.
    ws%ncache = 0
    ws%base_valid = .false.
    if (allocated(ws%cache_z)) deallocate (ws%cache_z, ws%cache_y, ws%cache_idx, ws%cache_has_y)
    if (allocated(ws%base_rhs)) deallocate (ws%base_rhs, ws%base_sol)
  end subroutine active_set_workspace_free

  !> Solve from the start x (which predicts the first active set); x returns the solution.
  !> With `ws` the factorisation is kept for the next call with the same matrix a.
  subroutine active_set_solve(a, f, kind, bnd, x, settings, res, st, ws)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(active_set_settings_t), intent(in) :: settings
    type(active_set_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(active_set_workspace_t), intent(inout), optional, target :: ws
    type(active_set_workspace_t), target :: local
    type(active_set_workspace_t), pointer :: w
    type(active_set_run_t) :: run
    logical, allocatable :: fixed(:), fixed_new(:)
    real(dp), allocatable :: g(:), rhs(:), xb(:)
    integer :: it, istat
    logical :: cycled

    if (present(ws)) then
      w => ws
    else
      w => local
    end if
    allocate (fixed(a%n), fixed_new(a%n), g(a%n), rhs(a%n), xb(a%n), stat=istat)
    if (istat /= 0) then
      call set_alloc_error(st, int(a%n, i8) * (3 * storage_size(1.0_dp) + 2 * storage_size(.true.)) / 8, &
                           'the work vectors of the active-set method')
      return
    end if
    if (any(x /= 0.0_dp)) then
      ! warm start (e.g. the interpolated coarser solution): its contact set is the first
      ! guess; the residual A x - F of an interpolated field is O(1) at the new nodes and
      ! would mispredict where u and its flux are both small
      fixed = kind == BOUND_FIXED .or. (kind == BOUND_LOWER .and. x <= bnd)
    else
      call predict_fixed(a, f, kind, bnd, x, g, fixed)
    end if
    if (.not. w%have_factor) w%ar = a
    w%base_valid = .false.               ! f may differ from the last call's
    run%nhist = 0
    cycled = .false.
    do it = 1, settings%max_iter
      call reduced_rhs(a, f, bnd, fixed, xb, rhs)
      call solve_held_set(a, bnd, fixed, rhs, settings, w, x, res, st)
      if (st%code /= 0) exit
      res%iterations = it
      call predict_fixed(a, f, kind, bnd, x, g, fixed_new)
      if (all(fixed_new .eqv. fixed)) then
        res%converged = .true.
        exit
      end if
      ! cycle detection: the new set was tried before
      call remember(run, it, fixed)
      if (seen(run, fixed_new)) then
        cycled = .true.
        exit
      end if
      fixed = fixed_new
    end do
    res%nnz_factor = w%chol%nnz_factor
    res%ordering = w%chol%ordering
    if (.not. present(ws)) call active_set_workspace_free(local)
    if (st%code /= 0) return
    where (kind == BOUND_LOWER) x = max(x, bnd)
    where (kind == BOUND_FIXED) x = bnd
    if (.not. res%converged) then
      if (settings%fallback) then
        call fall_back(a, f, kind, bnd, settings, cycled, x, res, st)
      else
        call set_warning(st, DS_WARN_NOT_CONVERGED, 'active set: ' // &
          trim(merge('cycle detected     ', 'iteration limit hit', cycled)) // ' after ' // itoa(res%iterations) // &
          ' iterations (no fallback); the projected iterate is returned')
      end if
    end if
    if (.not. is_ok(st)) return
    res%nactive = count(kind == BOUND_LOWER .and. x <= bnd)
    res%kkt_residual = kkt_residual(a, f, kind, bnd, x, g)
  end subroutine active_set_solve

  !> Right-hand side of the reduced system M(fixed) x = rhs: the bound values of the held
  !> unknowns moved to the right (xb is workspace).
  subroutine reduced_rhs(a, f, bnd, fixed, xb, rhs)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:)
    logical, intent(in) :: fixed(:)
    real(dp), intent(inout) :: xb(:), rhs(:)
    xb = 0.0_dp
    where (fixed) xb = bnd
    call csr_matvec(a, xb, rhs)
    rhs = f - rhs
    where (fixed) rhs = bnd
  end subroutine reduced_rhs

  !> One active-set step: x = M(fixed)^{-1} rhs, by a solve with the kept factor when its
  !> held set is `fixed`, by bordering the kept factor when that is predicted cheaper (and
  !> accurate enough; bordering_pays), else by a (re)factorisation of M(fixed).  Updates the
  !> counters in `res`.
  subroutine solve_held_set(a, bnd, fixed, rhs, settings, w, x, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: bnd(:)
    logical, intent(in) :: fixed(:)
    real(dp), intent(in) :: rhs(:)
    type(active_set_settings_t), intent(in) :: settings
    type(active_set_workspace_t), intent(inout) :: w
    real(dp), intent(inout) :: x(:)
    type(active_set_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    integer :: k
    logical :: border

    k = -1
    border = .false.
    if (w%have_factor) then
      k = count(w%fixed .neqv. fixed)
      if (k > 0) border = bordering_pays(settings, w%chol, k, uncached_count(w, fixed))
    end if
    if (k == 0) then
      call cholesky_solve(w%chol, rhs, x, st)
      call keep_base(rhs, x, w, st)
    else if (border) then
      call bordered_solve(a, w, settings%max_lowrank, fixed, rhs, bnd, x, st)
      res%lowrank_solves = res%lowrank_solves + 1
      ! bordering on a badly conditioned factor (e.g. a penalised matrix) can lose the
      ! accuracy a factorisation of M(F) would have: then refactorise after all
      if (st%code == 0) then
        if (backward_error(a, fixed, rhs, x) > settings%bordered_tol) then
          border = .false.
          res%lowrank_solves = res%lowrank_solves - 1
        end if
      end if
    end if
    if (k /= 0 .and. .not. border .and. st%code == 0) then
      call factor_reduced(a, fixed, settings, w, res, st)
      if (st%code /= 0) return
      call cholesky_solve(w%chol, rhs, x, st)
      call keep_base(rhs, x, w, st)
    end if
  end subroutine solve_held_set

  !> Remember the plain solve just done (held set = the factor's) for bordered steps.
  subroutine keep_base(rhs, x, w, st)
    real(dp), intent(in) :: rhs(:), x(:)
    type(active_set_workspace_t), intent(inout) :: w
    type(status_t), intent(in) :: st
    if (st%code /= 0) return
    w%base_rhs = rhs
    w%base_sol = x
    w%base_valid = .true.
  end subroutine keep_base

  !> Bordering with k changed unknowns, `fresh` of them not cached (one solve plus, when
  !> fresh > 0, one more solve and a block solve with 2 right-hand sides per fresh unknown)
  !> is predicted cheaper than a numeric refactorisation of chol's pattern and its solve
  !> (refactor_solves): a choice from the factor's statistics, the same on every run.
  pure logical function bordering_pays(settings, chol, k, fresh)
    type(active_set_settings_t), intent(in) :: settings
    type(cholesky_t), intent(in) :: chol
    integer, intent(in) :: k, fresh
    real(dp) :: bordered
    if (k > settings%max_lowrank) then
      bordering_pays = .false.
    else if (.not. settings%lowrank_by_cost) then
      bordering_pays = .true.
    else
      ! a solve with m right-hand sides costs about (1 + multi_rhs_cost m) single solves
      bordered = 1.0_dp + merge(1.0_dp + 2.0_dp * multi_rhs_cost * fresh, 0.0_dp, fresh > 0)
      bordering_pays = bordered < refactor_solves(chol) + 1.0_dp
    end if
  end function bordering_pays

  !> The cost of a numeric refactorisation of chol's pattern in single solves with chol:
  !> max(refactor_solves_min, fl / (4 nnz(L)) / refactor_speedup).
  pure real(dp) function refactor_solves(chol)
    type(cholesky_t), intent(in) :: chol
    refactor_solves = refactor_solves_min
    if (chol%nnz_factor > 0) refactor_solves = max(refactor_solves_min, &
      chol%flops / (4.0_dp * real(chol%nnz_factor, dp)) / refactor_speedup)
  end function refactor_solves

  !> The unknowns held at their bound by the next step: fixed ones, and bounded ones with
  !> g_i - A_ii (x_i - bnd_i) > 0 for the current x (g = A x - F is left in g).
  subroutine predict_fixed(a, f, kind, bnd, x, g, at_bound)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:), x(:)
    real(dp), intent(inout) :: g(:)
    logical, intent(out) :: at_bound(:)
    integer :: j
    call csr_matvec(a, x, g)
    g = g - f
    at_bound = kind == BOUND_FIXED
    do j = 1, a%n
      if (kind(j) == BOUND_LOWER) at_bound(j) = g(j) - a%val(a%diag(j)) * (x(j) - bnd(j)) > 0.0_dp
    end do
  end subroutine predict_fixed

  !> Factorise M(held) (numeric only after the first time) and keep it in the workspace.
  subroutine factor_reduced(a, held, settings, w, res, st)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: held(:)
    type(active_set_settings_t), intent(in) :: settings
    type(active_set_workspace_t), intent(inout) :: w
    type(active_set_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    call reduced_values(a, held, w%ar)
    if (.not. w%have_factor) then
      call cholesky_factor(w%ar, w%chol, st, settings%ordering, settings%perm)
    else
      call cholesky_refactor(w%ar, w%chol, st)
    end if
    if (st%code /= 0) return
    w%have_factor = .true.
    w%fixed = held
    w%ncache = 0                       ! the cached columns belonged to the old factor
    res%factorisations = res%factorisations + 1
  end subroutine factor_reduced

  !> Three hashes of a set S: its size and sum_{j in S} g_k^j mod p_k for two primes p_k
  !> near 2^31 (g_k of large order).  Unlike sums of j and j^2, which distinct sets share
  !> ({1, 5, 6} and {2, 3, 7}, and every shift of them), g^j is not a polynomial in j, so
  !> two distinct sets agree in both sums by chance only: about once in p_1 p_2 = 4.6e18
  !> (for the history_len sets compared per step).  A false cycle ends the active-set
  !> method early (projected SOR then finishes).
  pure function set_hash(s) result(h)
    logical, intent(in) :: s(:)
    integer(i8) :: h(3)
    integer(i8), parameter :: p(2) = [2147483647_i8, 2147483629_i8]
    integer(i8), parameter :: g(2) = [16807_i8, 48271_i8]
    integer(i8) :: gj(2)
    integer :: j
    h = 0
    gj = 1
    do j = 1, size(s)
      gj = mod(gj * g, p)                ! g^j mod p (products < 2^47)
      if (.not. s(j)) cycle
      h(1) = h(1) + 1
      h(2:3) = mod(h(2:3) + gj, p)
    end do
  end function set_hash

  !> Record the hash of the set s tried in iteration it (a ring of history_len sets).
  subroutine remember(run, it, s)
    type(active_set_run_t), intent(inout) :: run
    integer, intent(in) :: it
    logical, intent(in) :: s(:)
    run%nhist = min(run%nhist + 1, history_len)
    run%hist(:, 1 + mod(it - 1, history_len)) = set_hash(s)
  end subroutine remember

  !> The set s (by its hash) was tried before.
  logical function seen(run, s)
    type(active_set_run_t), intent(in) :: run
    logical, intent(in) :: s(:)
    integer(i8) :: h(3)
    integer :: j
    h = set_hash(s)
    seen = .false.
    do j = 1, run%nhist
      if (all(run%hist(:, j) == h)) seen = .true.
    end do
  end function seen

  !> Projected SOR from the current feasible iterate (cycle or iteration limit).
  subroutine fall_back(a, f, kind, bnd, settings, cycled, x, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    type(active_set_settings_t), intent(in) :: settings
    logical, intent(in) :: cycled
    real(dp), intent(inout) :: x(:)
    type(active_set_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    type(psor_settings_t) :: ps
    type(psor_result_t) :: pr
    res%fallback = .true.
    ps%omega = 1.0_dp
    ps%tol = settings%fallback_tol
    ps%max_iter = settings%fallback_max_iter
    call psor_solve(a, f, kind, bnd, x, ps, pr, st)
    res%converged = pr%converged
    ! a converged fallback is a converged solve (res%fallback tells it was needed); only a
    ! fallback that stopped at its limit is a warning (callers map it to "limit reached")
    if (is_ok(st) .and. .not. pr%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'active set: ' // &
      trim(merge('cycle detected     ', 'iteration limit hit', cycled)) // ' after ' // itoa(res%iterations) // &
      ' iterations; projected SOR fallback, ' // itoa(pr%iterations) // ' sweeps, not converged')
  end subroutine fall_back

  !> ar = M(held): the values of a with identity rows and columns for the held unknowns.
  pure subroutine reduced_values(a, held, ar)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: held(:)
    type(csr_t), intent(inout) :: ar
    integer :: i, p
    do i = 1, a%n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (held(i) .or. held(a%col(p))) then
          ar%val(p) = 0.0_dp
        else
          ar%val(p) = a%val(p)
        end if
      end do
      if (held(i)) ar%val(a%diag(i)) = 1.0_dp
    end do
  end subroutine reduced_values

  !> Normwise backward error of x for M(held) x = b (M(held): a with identity rows and
  !> columns for the held unknowns): ||M x - b||_inf / (||M||_inf ||x||_inf + ||b||_inf).
  real(dp) function backward_error(a, held, b, x) result(eta)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: held(:)
    real(dp), intent(in) :: b(:), x(:)
    real(dp) :: ri, row_norm, r_max, m_norm
    integer :: i, p
    r_max = 0.0_dp
    m_norm = 1.0_dp
    do i = 1, a%n
      if (held(i)) then
        ri = x(i) - b(i)
      else
        ri = -b(i)
        row_norm = 0.0_dp
        do p = a%rowptr(i), a%rowptr(i + 1) - 1
          if (held(a%col(p))) cycle
          ri = ri + a%val(p) * x(a%col(p))
          row_norm = row_norm + abs(a%val(p))
        end do
        m_norm = max(m_norm, row_norm)
      end if
      r_max = max(r_max, abs(ri))
    end do
    eta = r_max / (m_norm * maxval(abs(x)) + maxval(abs(b)))
  end function backward_error

  !> Number of unknowns whose held status differs from the kept factor's and whose columns
  !> are not cached yet.
  integer function uncached_count(w, held) result(nfresh)
    type(active_set_workspace_t), intent(in) :: w
    logical, intent(in) :: held(:)
    integer :: i
    nfresh = 0
    do i = 1, size(held)
      if (w%fixed(i) .neqv. held(i)) then
        if (cache_position(w, i) == 0) nfresh = nfresh + 1
      end if
    end do
  end function uncached_count

  !> Position of unknown i in the bordering cache (0: not cached).
  pure integer function cache_position(w, i) result(pos)
    type(active_set_workspace_t), intent(in) :: w
    integer, intent(in) :: i
    integer :: j
    pos = 0
    do j = 1, w%ncache
      if (w%cache_idx(j) == i) then
        pos = j
        return
      end if
    end do
  end function cache_position

  !> Make z_d = M1^{-1} e_d (every d of `d`) and y_d = M1^{-1} u_d (u_d = column d of a without
  !> the rows held in the kept factor; where need_y) available, with one block solve for
  !> the missing columns.  Cached unknowns no longer in d are dropped when room is needed
  !> (capacity max_lowrank).
  subroutine cache_columns(a, w, d, need_y, capacity, st)
    type(csr_t), intent(in) :: a
    type(active_set_workspace_t), intent(inout) :: w
    integer, intent(in) :: d(:), capacity
    logical, intent(in) :: need_y(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: zlist(:), ylist(:), pos(:)
    real(dp), allocatable :: rhs(:,:), sol(:,:)
    integer :: n, j, p, mz, my, keep, c, ist
    n = a%n
    if (.not. allocated(w%cache_z)) then
      allocate (w%cache_idx(capacity), w%cache_has_y(capacity), w%cache_z(n, capacity), w%cache_y(n, capacity), &
                stat=ist)
      if (alloc_failed(ist, st, 'the active set column cache', 2_i8 * n * capacity, BYTES_REAL)) return
      w%ncache = 0
    end if
    zlist = pack(d, [(cache_position(w, d(j)) == 0, j=1, size(d))])
    mz = size(zlist)
    if (w%ncache + mz > capacity) then
      ! keep only the cached unknowns that are still changed
      keep = 0
      do j = 1, w%ncache
        if (any(d == w%cache_idx(j))) then
          keep = keep + 1
          w%cache_idx(keep) = w%cache_idx(j)
          w%cache_has_y(keep) = w%cache_has_y(j)
          w%cache_z(:, keep) = w%cache_z(:, j)
          w%cache_y(:, keep) = w%cache_y(:, j)
        end if
      end do
      w%ncache = keep
    end if
    ! new cache slots for the unknowns without z
    do j = 1, mz
      w%ncache = w%ncache + 1
      w%cache_idx(w%ncache) = zlist(j)
      w%cache_has_y(w%ncache) = .false.
    end do
    allocate (pos(size(d)), stat=ist)
    if (alloc_failed(ist, st, 'the active set changes', size(d), BYTES_INT)) return
    do j = 1, size(d)
      pos(j) = cache_position(w, d(j))
    end do
    ylist = pack(d, need_y .and. .not. w%cache_has_y(pos))
    my = size(ylist)
    if (mz + my == 0) return
    allocate (rhs(n, mz + my), sol(n, mz + my), stat=ist)
    if (alloc_failed(ist, st, 'the active set block solve', 2_i8 * n * (mz + my), BYTES_REAL)) return
    rhs = 0.0_dp
    do j = 1, mz
      rhs(zlist(j), j) = 1.0_dp
    end do
    do j = 1, my
      do p = a%rowptr(ylist(j)), a%rowptr(ylist(j) + 1) - 1      ! a symmetric: column = row
        if (.not. w%fixed(a%col(p))) rhs(a%col(p), mz + j) = a%val(p)
      end do
    end do
    call cholesky_solve(w%chol, rhs, sol, st)
    if (st%code /= 0) then
      w%ncache = w%ncache - mz                 ! the new slots hold nothing
      return
    end if
    do j = 1, mz
      w%cache_z(:, cache_position(w, zlist(j))) = sol(:, j)
    end do
    do j = 1, my
      c = cache_position(w, ylist(j))
      w%cache_y(:, c) = sol(:, mz + j)
      w%cache_has_y(c) = .true.
    end do
  end subroutine cache_columns

  !> x = M(held)^{-1} b by bordering on the kept factor of M(F1), F1 = w%fixed (see the
  !> module header); D = the k unknowns whose held status differs, R = the others not held.
  !> With Z = M1^{-1} E_D, C1 = Z(D, :) and, for r zero on D, A_RR^{-1} r = [s - Z C1^{-1} s(D)]_R
  !> with s = M1^{-1} r:
  !>   B(:, j) = u_dj with the rows of D removed (0 when d_j is held), so M1^{-1} B(:, j) =
  !>   y_dj - Z u_dj(D);  M1^{-1} b_R by a solve, or without one from the last plain solve
  !>   M1 s0 = b0 of this call (same F1, same f): b_R differs from b0 only in the rows of D
  !>   (zeroed) and by sum_d c_d (u_d without the rows of D), c_d = -bnd_d for an unknown
  !>   newly held and +bnd_d for one newly freed (its bound value moves between the sides), so
  !>   M1^{-1} b_R = s0 - Z b0(D) + sum_d c_d (y_d - Z u_d(D));
  !>   S = M(held)_DD - B^T A_RR^{-1} B,  x_D = S^{-1} (b_D - B^T A_RR^{-1} b_R),
  !>   x_R = A_RR^{-1} b_R - A_RR^{-1} B x_D.
  subroutine bordered_solve(a, w, capacity, held, b, bnd, x, st)
    type(csr_t), intent(in) :: a
    type(active_set_workspace_t), intent(inout) :: w
    integer, intent(in) :: capacity
    logical, intent(in) :: held(:)
    real(dp), intent(in) :: b(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(out) :: x(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: d(:), ipiv(:), pos(:)
    real(dp), allocatable :: z(:,:), c1(:,:), h(:,:), t(:,:), s(:,:), xd(:), ud(:,:), y0(:), cd(:)
    integer :: n, k, j, p, i, info, r, ist
    logical, allocatable :: in_d(:), need_y(:)
    external :: dgesv
    n = size(b)
    d = pack([(i, i=1, n)], w%fixed .neqv. held)
    k = size(d)
    ! c_d: the change of the bound value moved to the right-hand side (newly held: -bnd)
    allocate (cd(k), in_d(n), pos(k), ud(k, k), y0(n), h(n, k + 1), z(n, k), stat=ist)
    if (alloc_failed(ist, st, 'the bordered active set system', int(n, i8) * (2 * k + 3) + k * (k + 2_i8), BYTES_REAL)) &
      return
    do j = 1, k
      cd(j) = merge(-bnd(d(j)), bnd(d(j)), held(d(j)))
    end do
    need_y = .not. held(d) .or. (w%base_valid .and. cd /= 0.0_dp)
    call cache_columns(a, w, d, need_y, capacity, st)
    if (st%code /= 0) return
    in_d = .false.
    in_d(d) = .true.
    do j = 1, k
      pos(j) = cache_position(w, d(j))
    end do
    z(:, :) = w%cache_z(:, pos)
    c1 = z(d, :)
    ! u_dj(D): entries of column d_j of a in the rows of D that are not held in F1
    ud = 0.0_dp
    do j = 1, k
      do i = 1, k
        if (.not. w%fixed(d(i))) ud(i, j) = a_value(d(i), d(j))
      end do
    end do
    ! H = [M1^{-1} B, M1^{-1} b_R]
    if (w%base_valid) then
      y0 = w%base_sol - matmul(z, w%base_rhs(d))
      do j = 1, k
        if (cd(j) /= 0.0_dp) y0 = y0 + cd(j) * (w%cache_y(:, pos(j)) - matmul(z, ud(:, j)))
      end do
    else
      call cholesky_solve(w%chol, merge(0.0_dp, b, in_d), y0, st)
      if (st%code /= 0) return
    end if
    do j = 1, k
      if (held(d(j))) then
        h(:, j) = 0.0_dp                        ! a held unknown's column is e_j: no coupling
      else
        h(:, j) = w%cache_y(:, pos(j)) - matmul(z, ud(:, j))
      end if
    end do
    h(:, k + 1) = y0
    ! G = A_RR^{-1} [B, b_R] = H - Z C1^{-1} H(D, :)   (stored in h)
    t = h(d, :)
    allocate (ipiv(k), s(k, k), xd(k), stat=ist)
    if (alloc_failed(ist, st, 'the capacitance system', k * (k + 2_i8), BYTES_REAL)) return
    call dgesv(k, k + 1, c1, k, ipiv, t, k, info)
    if (info /= 0) then
      call set_error(st, DS_ERR_LAPACK, 'active set: capacitance matrix singular (dgesv info = ' // itoa(info) // ')')
      return
    end if
    h = h - matmul(z, t)
    ! S = M(held)_DD - B^T G_B,  x_D = S^{-1} (b_D - B^T G_b); B^T v by the sparse columns
    do j = 1, k
      do i = 1, k
        s(i, j) = m_dd(d(i), d(j)) - b_dot(i, h(:, j))
      end do
      xd(j) = b(d(j)) - b_dot(j, h(:, k + 1))
    end do
    call dgesv(k, 1, s, k, ipiv, xd, k, info)
    if (info /= 0) then
      call set_error(st, DS_ERR_LAPACK, 'active set: bordered system singular (dgesv info = ' // itoa(info) // ')')
      return
    end if
    x = h(:, k + 1) - matmul(h(:, 1:k), xd)
    x(d) = xd

  contains

    !> B(:, j)^T v: column d_j of M(held) restricted to R (zero when d_j is held).
    real(dp) function b_dot(j, v)
      integer, intent(in) :: j
      real(dp), intent(in) :: v(:)
      b_dot = 0.0_dp
      if (held(d(j))) return
      do p = a%rowptr(d(j)), a%rowptr(d(j) + 1) - 1
        r = a%col(p)
        if (in_d(r) .or. held(r)) cycle
        b_dot = b_dot + a%val(p) * v(r)
      end do
    end function b_dot

    !> The matrix entry a(i, j) (zero outside the pattern).
    real(dp) function a_value(i, j)
      integer, intent(in) :: i, j
      integer :: q
      a_value = 0.0_dp
      do q = a%rowptr(i), a%rowptr(i + 1) - 1
        if (a%col(q) == j) a_value = a%val(q)
      end do
    end function a_value

    !> Entry (i, j) of M(held) for i, j in D.
    real(dp) function m_dd(i, j)
      integer, intent(in) :: i, j
      if (held(i) .or. held(j)) then
        m_dd = merge(1.0_dp, 0.0_dp, i == j)
      else
        m_dd = a_value(i, j)
      end if
    end function m_dd
  end subroutine bordered_solve
end module dualsig_solver_active_set
