!> Equilibrium elements (Section 4): divergence-free linear vector fields on a triangle,
!> described by six flux parameters.
!>
!> Convention (the paper's C_e^{-1}).  Triangle a1 a2 a3 counter-clockwise; side
!> S_k = a_k a_{k+1} (a4 = a1) with length l_k and outward unit normal nu^(k) -- the same
!> as local edge k of dualsig_mesh.  The flux parameters are the values of q.nu at the two
!> ends of each side:
!>
!>     beta_1 = q(a1).nu^(3)   beta_2 = q(a1).nu^(1)      (side 3 at a1, side 1 at a1)
!>     beta_3 = q(a2).nu^(1)   beta_4 = q(a2).nu^(2)      (side 1 at a2, side 2 at a2)
!>     beta_5 = q(a3).nu^(2)   beta_6 = q(a3).nu^(3)      (side 2 at a3, side 3 at a3)
!>
!> so w^e = (q1(a1), q2(a1), q1(a2), q2(a2), q1(a3), q2(a3)) = C_e beta with
!> C_e^{-1} = blockdiag([nu3; nu1], [nu1; nu2], [nu2; nu3]) (rows are normals).
!> div q = 0 on T  <=>  (4.9): l1 (beta_2 + beta_3) + l2 (beta_4 + beta_5) + l3 (beta_6 + beta_1) = 0
!> (the integral of q.nu over the boundary of T, sides integrated exactly by the trapezoid
!> rule since q.nu is linear on a side).  A_e = C_e^T int(Phi1 Phi1^T + Phi2 Phi2^T) C_e
!> (4.6): beta^T A_e beta = int_T |q|^2.  b_e of (4.7) is computed as
!> b_e = -C_e^T int_T (lambda_1 Phi1 + lambda_2 Phi2): the transpose follows from
!> (lambda, q) = int lambda . (Phi^T C_e beta); the print shows C_e.
module dualsig_elements_equilibrium
  use dualsig_kinds, only: dp
  use dualsig_quadrature, only: tri_points_t
  use dualsig_elements_p1, only: p1_element_mass
  use dualsig_status, only: status_t, set_error, DS_ERR_LAPACK
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: param_side, param_vertex, equilibrium_sides, equilibrium_c_matrix, &
            equilibrium_element_matrix, equilibrium_div_row, equilibrium_element_load, &
            equilibrium_field, equilibrium_c_of, equilibrium_field_xy, equilibrium_c_of_normals

  integer, parameter :: param_side(6) = [3, 1, 1, 2, 2, 3]     !! side of parameter k
  integer, parameter :: param_vertex(6) = [1, 1, 2, 2, 3, 3]   !! vertex of parameter k

contains

  !> Outward unit normals nu(:, k) and lengths l(k) of the sides S_k = a_k a_{k+1}.  The
  !> length as sqrt(dx^2 + dy^2), not hypot: libm's hypot took 6-7 % of an adaptive P2 run
  !> (C_e is formed anew for the elements, the loads, the bounds and the errors); the squares
  !> overflow only for sides beyond 1e154, where the triangle's area does too.
  pure subroutine equilibrium_sides(xy, nu, l)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: nu(2, 3), l(3)
    real(dp) :: d(2)
    integer :: k
    do k = 1, 3
      d = xy(:, mod(k, 3) + 1) - xy(:, k)
      l(k) = sqrt(d(1)**2 + d(2)**2)
      nu(:, k) = [d(2), -d(1)] / l(k)          ! counter-clockwise: outward is to the right
    end do
  end subroutine equilibrium_sides

  !> C_e (w = C_e beta), in closed form.  The printed C_e^{-1} is block diagonal: the two
  !> parameters of vertex a_v are q(a_v) . nu of its two sides, so C_e^{-1} =
  !> blockdiag(N_1, N_2, N_3) with N_v the 2 x 2 matrix whose rows are those normals, and
  !> C_e = blockdiag(N_1^{-1}, N_2^{-1}, N_3^{-1}).  det N_v is the sine of the angle between
  !> the two normals (the interior angle at a_v): zero only for a degenerate triangle.
  pure subroutine equilibrium_c_matrix(xy, c, st)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: c(6, 6)
    type(status_t), intent(out) :: st
    real(dp) :: nu(2, 3), l(3)
    call equilibrium_sides(xy, nu, l)
    call equilibrium_c_of_normals(nu, c, st)
  end subroutine equilibrium_c_matrix

  !> equilibrium_c_matrix from the outward unit normals nu of the sides (equilibrium_sides).
  pure subroutine equilibrium_c_of_normals(nu, c, st)
    real(dp), intent(in) :: nu(2, 3)
    real(dp), intent(out) :: c(6, 6)
    type(status_t), intent(out) :: st
    real(dp) :: n(2, 2), det
    integer :: v, k1, k2
    c = 0.0_dp
    do v = 1, 3
      k1 = 2 * v - 1                         ! parameters 2v-1, 2v belong to vertex v
      k2 = 2 * v
      n(1, :) = nu(:, param_side(k1))
      n(2, :) = nu(:, param_side(k2))
      det = n(1, 1) * n(2, 2) - n(1, 2) * n(2, 1)
      if (.not. abs(det) > 0.0_dp) then
        call set_error(st, DS_ERR_LAPACK, 'equilibrium element: C_e^{-1} is singular at vertex ' // &
          itoa(v) // ' (parallel sides): degenerate triangle')
        return
      end if
      ! rows 2v-1, 2v of w (the components of q(a_v)) from beta_{2v-1}, beta_{2v}
      c(k1, k1) = n(2, 2) / det
      c(k1, k2) = -n(1, 2) / det
      c(k2, k1) = -n(2, 1) / det
      c(k2, k2) = n(1, 1) / det
    end do
  end subroutine equilibrium_c_of_normals

  !> C_e of a triangle known to be non-degenerate (equilibrium_c_matrix has accepted it):
  !> the fields keep their flux parameters only and compute C_e where they are evaluated,
  !> a few operations instead of 288 bytes per triangle in memory.
  pure function equilibrium_c_of(xy) result(c)
    real(dp), intent(in) :: xy(2, 3)
    real(dp) :: c(6, 6)
    type(status_t) :: st
    call equilibrium_c_matrix(xy, c, st)
  end function equilibrium_c_of

  !> A_e = C_e^T kron(M_e, I_2) C_e: beta^T A_e beta = int_T |q|^2  (4.6).  With C_e block
  !> diagonal (2 x 2 blocks C_v), block (v, w) of A_e is M_e(v, w) C_v^T C_w.
  pure subroutine equilibrium_element_matrix(xy, c, ae)
    real(dp), intent(in) :: xy(2, 3), c(6, 6)
    real(dp), intent(out) :: ae(6, 6)
    real(dp) :: me(3, 3), g(2, 2)
    integer :: v, w, iv, iw
    call p1_element_mass(xy, me)
    do w = 1, 3
      iw = 2 * w - 1
      do v = 1, w
        iv = 2 * v - 1
        g = matmul(transpose(c(iv:iv + 1, iv:iv + 1)), c(iw:iw + 1, iw:iw + 1))
        ae(iv:iv + 1, iw:iw + 1) = me(v, w) * g
        ae(iw:iw + 1, iv:iv + 1) = me(v, w) * transpose(g)    ! exact symmetry for the Cholesky factor
      end do
    end do
  end subroutine equilibrium_element_matrix

  !> Coefficients of the divergence condition (4.9): d . beta = int_{dT} q.nu = |T| div q.
  pure subroutine equilibrium_div_row(xy, d)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: d(6)
    real(dp) :: nu(2, 3), l(3)
    integer :: k
    call equilibrium_sides(xy, nu, l)
    do k = 1, 6
      d(k) = 0.5_dp * l(param_side(k))
    end do
  end subroutine equilibrium_div_row

  !> b_e = -C_e^T int_T (lam_1 Phi1 + lam_2 Phi2) (4.7), from the values lam(:, k) of the
  !> particular field at the quadrature points tp of the triangle.
  pure subroutine equilibrium_element_load(c, tp, lam, be)
    real(dp), intent(in) :: c(6, 6)
    type(tri_points_t), intent(in) :: tp
    real(dp), intent(in) :: lam(:,:)
    real(dp), intent(out) :: be(6)
    real(dp) :: v(6)
    integer :: k, a
    v = 0.0_dp
    do k = 1, tp%n
      do a = 1, 3
        v(2 * a - 1) = v(2 * a - 1) + tp%w(k) * lam(1, k) * tp%bary(a, k)
        v(2 * a) = v(2 * a) + tp%w(k) * lam(2, k) * tp%bary(a, k)
      end do
    end do
    be = -matmul(transpose(c), v)
  end subroutine equilibrium_element_load

  !> The field q at the point with barycentric coordinates bary, from C_e and beta.
  pure function equilibrium_field(c, beta, bary) result(q)
    real(dp), intent(in) :: c(6, 6), beta(6), bary(3)
    real(dp) :: q(2)
    real(dp) :: w(6)
    w = matmul(c, beta)
    q = bary(1) * w(1:2) + bary(2) * w(3:4) + bary(3) * w(5:6)
  end function equilibrium_field

  !> q(x) = Phi(x)^T C_e beta on the triangle xy (equilibrium_field with C_e computed by
  !> equilibrium_c_of), at the point with barycentric coordinates bary.
  pure function equilibrium_field_xy(xy, beta, bary) result(q)
    real(dp), intent(in) :: xy(2, 3), beta(6), bary(3)
    real(dp) :: q(2)
    q = equilibrium_field(equilibrium_c_of(xy), beta, bary)
  end function equilibrium_field_xy
end module dualsig_elements_equilibrium
