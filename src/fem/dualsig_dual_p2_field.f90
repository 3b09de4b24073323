!> The admissible dual field of problem P2 (Sections 4-6): lambda^h = lambda^f + q^h, q^h
!> the equilibrium-element field given by its flux parameters beta_e (Section 4; the
!> element matrices C_e are computed where the field is evaluated, equilibrium_c_of), and
!> the particular field lambda^f either
!>  - polynomial (the default): div lambda^f = -Pi_1 f on every triangle (Pi_1 f = f_T +
!>    g_T . (x - x_T), the L2 projection onto linear functions) and lambda^f . nu = 0 on
!>    Gamma_a: a piecewise linear part in the same parameters, beta_f, with div = -f_T, plus
!>    on every triangle a quadratic bubble with zero normal trace and div = -g_T . (x - x_T),
!>    sigma_T = sum_i c_i lambda_{i+1} lambda_{i+2} (a_{i+2} - a_{i+1}) (barycentric
!>    lambda_i, indices mod 3): div sigma_T = sum_k (c_{k-1} - c_{k+1}) lambda_k, so the
!>    coefficients alpha_k = -g_T . (a_k - x_T) of the target (they sum to zero) give
!>    c_i = (alpha_{i+1} - alpha_{i+2}) / 3.  lambda^h is then piecewise quadratic, every
!>    integral of the bounds a polynomial, and f - Pi_1 f enters them as an oscillation
!>    term; or
!>  - the paper's lambda_bar + curl(omega) of dualsig_particular_field (div lambda^f = -f
!>    exactly, lambda^f . nu = -g_h on Gamma_a; Remark 6.5).
!> Produced by dualsig_problem_dual_p2, read by the estimates and the output.
module dualsig_dual_p2_field
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_elements_equilibrium, only: equilibrium_field_xy, equilibrium_c_of
  use dualsig_quadrature, only: tri_points_t
  use dualsig_particular_field, only: particular_field_t, lambda_f_at
  implicit none
  private

  public :: dual_p2_field_t, dual_p2_lambda, dual_p2_lambda_points, bubble_coefficients, bubble_value, &
            bubble_load_moments

  type :: dual_p2_field_t
    logical :: polynomial = .false.         !! lambda^f is beta_f (else pf)
    type(particular_field_t) :: pf          !! lambda^f = lambda_bar + curl(omega) (not polynomial)
    real(dp), allocatable :: beta_f(:,:)    !! (6, ntri) flux parameters of lambda^f (polynomial)
    real(dp), allocatable :: bubble(:,:)    !! (3, ntri) c_i of the bubble sigma_T (polynomial)
    real(dp), allocatable :: beta(:,:)      !! (6, ntri) flux parameters of q^h
  end type dual_p2_field_t

contains

  !> lambda^h = lambda^f + q^h at the point with barycentric coordinates bary of triangle t
  !> (f is used only by the non-polynomial lambda^f).
  function dual_p2_lambda(field, mesh, f, t, bary) result(v)
    type(dual_p2_field_t), intent(in) :: field
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: t
    real(dp), intent(in) :: bary(3)
    real(dp) :: v(2)
    real(dp) :: p(2), beta(6), xy(2, 3)
    integer :: k
    if (field%polynomial) then
      ! fixed-size locals: the array expressions as actual arguments made heap temporaries
      ! (a malloc and a free per call: a fifth of a manufactured run's verification)
      beta = field%beta(:, t) + field%beta_f(:, t)
      do k = 1, 3
        xy(:, k) = mesh%xy(:, mesh%tri(k, t))
      end do
      v = equilibrium_field_xy(xy, beta, bary) + bubble_value(xy, field%bubble(:, t), bary)
      return
    end if
    do k = 1, 3
      xy(:, k) = mesh%xy(:, mesh%tri(k, t))
    end do
    p = matmul(xy, bary)
    v = lambda_f_at(field%pf, mesh, f, t, p(1), p(2)) + equilibrium_field_xy(xy, field%beta(:, t), bary)
  end function dual_p2_lambda

  !> lambda^h = lambda^f + q^h at every point of tp, a point set of triangle t: lam(:, k) is
  !> dual_p2_lambda at tp%bary(:, k), to the last bit, with C_e beta formed once for the
  !> triangle instead of once per point.
  subroutine dual_p2_lambda_points(field, mesh, f, t, tp, lam)
    type(dual_p2_field_t), intent(in) :: field
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: t
    type(tri_points_t), intent(in) :: tp
    real(dp), intent(out) :: lam(:,:)        !! (2, tp%n)
    real(dp) :: xy(2, 3), w(6), p(2)
    integer :: k
    do k = 1, 3
      xy(:, k) = mesh%xy(:, mesh%tri(k, t))
    end do
    if (field%polynomial) then
      w = matmul(equilibrium_c_of(xy), field%beta(:, t) + field%beta_f(:, t))
    else
      w = matmul(equilibrium_c_of(xy), field%beta(:, t))
    end if
    do k = 1, tp%n
      ! the sum of equilibrium_field, in its order
      lam(:, k) = tp%bary(1, k) * w(1:2) + tp%bary(2, k) * w(3:4) + tp%bary(3, k) * w(5:6)
      if (field%polynomial) then
        lam(:, k) = lam(:, k) + bubble_value(xy, field%bubble(:, t), tp%bary(:, k))
      else
        p = matmul(xy, tp%bary(:, k))
        lam(:, k) = lambda_f_at(field%pf, mesh, f, t, p(1), p(2)) + lam(:, k)
      end if
    end do
  end subroutine dual_p2_lambda_points

  !> The coefficients c of the bubble with div sigma = -g . (x - x_T) on the triangle xy.
  pure function bubble_coefficients(xy, g) result(c)
    real(dp), intent(in) :: xy(2, 3), g(2)
    real(dp) :: c(3)
    real(dp) :: alpha(3), centroid(2)
    integer :: k
    centroid = sum(xy, dim=2) / 3.0_dp
    do k = 1, 3
      alpha(k) = -dot_product(g, xy(:, k) - centroid)
    end do
    do k = 1, 3
      c(k) = (alpha(mod(k, 3) + 1) - alpha(mod(k + 1, 3) + 1)) / 3.0_dp
    end do
  end function bubble_coefficients

  !> sigma(bary) = sum_i c_i lambda_{i+1} lambda_{i+2} (a_{i+2} - a_{i+1}) on the triangle xy.
  pure function bubble_value(xy, c, bary) result(v)
    real(dp), intent(in) :: xy(2, 3), c(3), bary(3)
    real(dp) :: v(2)
    integer :: i, j, k
    v = 0.0_dp
    do i = 1, 3
      j = mod(i, 3) + 1
      k = mod(i + 1, 3) + 1
      v = v + c(i) * bary(j) * bary(k) * (xy(:, k) - xy(:, j))
    end do
  end function bubble_value

  !> The moments v(2a-1:2a) = int_T sigma lambda_a of the bubble sigma (bubble_value) against
  !> the P1 basis, in closed form: sigma lambda_a is a cubic in the barycentric coordinates,
  !> and int_T lambda_1^p lambda_2^q lambda_3^r = 2 |T| p! q! r! / (p + q + r + 2)!, so
  !> int lambda_j lambda_k lambda_a = |T| / 60 for three different indices and |T| / 30 when
  !> a is j or k.  (These are the vectors of equilibrium_element_load for lam = sigma.)
  pure function bubble_load_moments(xy, c) result(v)
    real(dp), intent(in) :: xy(2, 3), c(3)
    real(dp) :: v(6)
    real(dp) :: area, m
    integer :: i, j, k, a
    area = 0.5_dp * abs((xy(1, 2) - xy(1, 1)) * (xy(2, 3) - xy(2, 1)) - (xy(1, 3) - xy(1, 1)) * (xy(2, 2) - xy(2, 1)))
    v = 0.0_dp
    do i = 1, 3
      j = mod(i, 3) + 1
      k = mod(i + 1, 3) + 1
      do a = 1, 3
        m = merge(area / 60.0_dp, area / 30.0_dp, a == i)
        v(2 * a - 1:2 * a) = v(2 * a - 1:2 * a) + c(i) * m * (xy(:, k) - xy(:, j))
      end do
    end do
  end function bubble_load_moments
end module dualsig_dual_p2_field
