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
  public :: kkt_residual

  integer, parameter :: BOUND_FREE = 0       !! unconstrained unknown
  integer, parameter :: BOUND_LOWER = 1      !! x_i >= bnd(i)
  integer, parameter :: BOUND_FIXED = 2      !! x_i  = bnd(i)
  integer, parameter :: ROW_EQUALITY = 0     !! (B y)_k = e_k, free multiplier
  integer, parameter :: ROW_INEQUALITY = 1   !! (B y)_k >= e_k, multiplier >= 0

contains

  !> Relative KKT residual || r ||_2 / || F ||_2 over the unknowns that are not fixed,
  !> where g = A x - F and
  !>     r_i = g_i                           for free unknowns,
  !>     r_i = min(g_i, A_ii (x_i - bnd_i))  for lower-bounded unknowns
  !> (the natural residual of the diagonally scaled problem: zero exactly at the KKT
  !> point, in the units of F, hence invariant under scaling of F, A and x).
  !> When F vanishes on the unknowns that are not fixed the absolute norm is returned.
  !> `work` (size n) is scratch space.
  real(dp) function kkt_residual(a, f, kind, bnd, x, work) result(rel)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(in) :: x(:)
    real(dp), intent(inout) :: work(:)
    real(dp) :: num, den, r
    integer :: i
    call csr_matvec(a, x, work)
    num = 0.0_dp
    den = 0.0_dp
    do i = 1, a%n
      select case (kind(i))
      case (BOUND_FREE)
        r = work(i) - f(i)
      case (BOUND_LOWER)
        r = min(work(i) - f(i), a%val(a%diag(i)) * (x(i) - bnd(i)))
      case default
        cycle
      end select
      num = num + r * r
      den = den + f(i) * f(i)
    end do
    if (den > 0.0_dp) then
      rel = sqrt(num / den)
    else
      rel = sqrt(num)
    end if
  end function kkt_residual
end module dualsig_qp_types
