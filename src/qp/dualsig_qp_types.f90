!> Vocabulary of the quadratic programmes: the bound kinds of a bound-constrained QP,
!> the row kinds of a QP with linear constraints, and the KKT residual every solver of the
!> qp layer stops on.
!>
!> Bound-constrained QP (primal problems, P2 dual inner solves):
!>     minimise 1/2 x^T A x - F^T x   subject to   x_i free        (kind(i) = BOUND_FREE)
!>                                                 x_i >= bnd(i)   (kind(i) = BOUND_LOWER)
!>                                                 x_i  = bnd(i)   (kind(i) = BOUND_FIXED)
!> Linear constraints (Uzawa, Section 3 of the paper): row k of B is an equality
!> (B y)_k = e_k (ROW_EQUALITY, free multiplier) or an inequality (B y)_k >= e_k
!> (ROW_INEQUALITY, multiplier >= 0).
module dualsig_qp_types
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t, csr_matvec
  implicit none
  private

  public :: BOUND_FREE, BOUND_LOWER, BOUND_FIXED, ROW_EQUALITY, ROW_INEQUALITY
  public :: kkt_residual, kkt_scale, norm_acc_t, norm_acc_add, norm_acc_value

  integer, parameter :: BOUND_FREE = 0       !! unconstrained unknown
  integer, parameter :: BOUND_LOWER = 1      !! x_i >= bnd(i)
  integer, parameter :: BOUND_FIXED = 2      !! x_i  = bnd(i)
  integer, parameter :: ROW_EQUALITY = 0     !! (B y)_k = e_k, free multiplier
  integer, parameter :: ROW_INEQUALITY = 1   !! (B y)_k >= e_k, multiplier >= 0

  !> A sum of squares scale^2 ssq accumulated without overflow or underflow (norm_acc_add).
  type :: norm_acc_t
    real(dp) :: scale = 0.0_dp
    real(dp) :: ssq = 1.0_dp
  end type norm_acc_t

contains

  !> Relative KKT residual || r ||_2 / d over the unknowns that are not fixed, where
  !> g = A x - F and
  !>     r_i = g_i                           for free unknowns,
  !>     r_i = min(g_i, A_ii (x_i - bnd_i))  for lower-bounded unknowns
  !> (the natural residual of the diagonally scaled problem: zero exactly at the KKT
  !> point, in the units of F) and d = kkt_scale(a, f, kind, bnd), the size of the data of
  !> the problem in the same units; so the ratio is invariant under scaling of F, A and x.
  !> Both norms are accumulated with scaling (no overflow or underflow of the squares).
  !> `work` (size n) is scratch space; `scale` (optional): d computed once by the caller
  !> (an iteration that measures its residual repeatedly; d depends on the data only).
  real(dp) function kkt_residual(a, f, kind, bnd, x, work, scale) result(rel)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(in) :: x(:)
    real(dp), intent(inout) :: work(:)
    real(dp), intent(in), optional :: scale
    type(norm_acc_t) :: num
    real(dp) :: r
    integer :: i
    call csr_matvec(a, x, work)
    do i = 1, a%n
      select case (kind(i))
      case (BOUND_FREE)
        r = work(i) - f(i)
      case (BOUND_LOWER)
        r = min(work(i) - f(i), a%val(a%diag(i)) * (x(i) - bnd(i)))
      case default
        cycle
      end select
      call norm_acc_add(num, r)
    end do
    if (present(scale)) then
      rel = norm_acc_ratio(num, scale)
    else
      rel = norm_acc_ratio(num, kkt_scale(a, f, kind, bnd))
    end if
  end function kkt_residual

  !> The size of the data of a bound-constrained QP, the denominator of kkt_residual:
  !> d = || (F_eff, D bnd_L) ||_2, with F_eff = F - A_{.,X} bnd_X on the unknowns that are
  !> not fixed (X: the fixed ones; the load their values put on their neighbours) and
  !> D bnd_L = A_ii bnd_i on the lower-bounded ones.  d = 0 only when the solution is x = 0
  !> on the unknowns that are not fixed; kkt_residual is then the absolute ||r||.  Without
  !> F_eff a problem driven by fixed values alone (F = 0) would be measured in the units of A.
  real(dp) function kkt_scale(a, f, kind, bnd) result(d)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    type(norm_acc_t) :: acc
    real(dp) :: s
    integer :: i, p
    do i = 1, a%n
      if (kind(i) == BOUND_FIXED) cycle
      s = f(i)
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (kind(a%col(p)) == BOUND_FIXED) s = s - a%val(p) * bnd(a%col(p))
      end do
      call norm_acc_add(acc, s)
      if (kind(i) == BOUND_LOWER) call norm_acc_add(acc, a%val(a%diag(i)) * bnd(i))
    end do
    d = norm_acc_value(acc)
  end function kkt_scale

  !> Add v^2 to the sum of squares acc (kept as scale^2 ssq, as LAPACK's dlassq).
  pure subroutine norm_acc_add(acc, v)
    type(norm_acc_t), intent(inout) :: acc
    real(dp), intent(in) :: v
    real(dp) :: av
    av = abs(v)
    if (.not. av > 0.0_dp) then
      if (av /= av) acc%ssq = av                 ! NaN propagates
      return
    end if
    if (acc%scale < av) then
      acc%ssq = 1.0_dp + acc%ssq * (acc%scale / av)**2
      acc%scale = av
    else
      acc%ssq = acc%ssq + (av / acc%scale)**2
    end if
  end subroutine norm_acc_add

  !> sqrt of the sum of squares in acc.
  pure real(dp) function norm_acc_value(acc) result(v)
    type(norm_acc_t), intent(in) :: acc
    v = acc%scale * sqrt(acc%ssq)
  end function norm_acc_value

  !> sqrt(acc) / d without overflow or underflow of the norm (d = 0: sqrt(acc)).
  pure real(dp) function norm_acc_ratio(acc, d) result(ratio)
    type(norm_acc_t), intent(in) :: acc
    real(dp), intent(in) :: d
    if (d > 0.0_dp) then
      ratio = (acc%scale / d) * sqrt(acc%ssq)
    else
      ratio = norm_acc_value(acc)
    end if
  end function norm_acc_ratio
end module dualsig_qp_types
