!> Admissible particular field lambda^f of the second dual problem (problem P2:
!> -Lap u = f in Omega, u = 0 on Gamma_u, Signorini conditions on Gamma_a).
!>
!> The dual approximation of Section 4 is lambda^h = lambda^f + q^h with q^h in K_h, i.e. an
!> equilibrium field (div q^h = 0, piecewise linear, continuous normal flux) with
!> q^h . nu >= g_h on Gamma_a.  lambda^h lies in U_2 (div lambda + f = 0, lambda . nu >= 0 on
!> Gamma_a) exactly when lambda^f . nu = -g_h on Gamma_a, with g_h linear on every side of
!> Gamma_a (Section 4 after (A 4), and Remark 6.4 before (6.24)).  This module builds such a
!> lambda^f in three pieces:
!>
!> 1. lambda-bar (Section 4):  lambda_bar = ( -int_{x_start}^{x} f(t, y) dt, 0 ), so that
!>    div lambda_bar + f = 0.  The paper integrates from x_1 = 0; any x_start works.  The
!>    driver passes the left edge of the bounding box of the mesh
!>    (`particular_field_x_start`), so the integration paths stay in the bounding box:
!>    **a user source f must be defined (finite) on the whole bounding box of the mesh**,
!>    not only on Omega.
!> 2. g = -lambda_bar . nu on Gamma and, on every side S of Gamma_a, g_h = the L2(S)
!>    projection of g onto P_1(S) (Section 4, definition of g_h before (4.4)).
!> 3. A stream-function correction (Remark 6.5, (6.24)-(6.25), in a variant that removes only
!>    the non-linear part g - g_h of the flux instead of all of it): on a side e of Gamma_a
!>    from a to b (length L, arc length t in [0, L] from a)
!>        omega_e(t) = -int_0^t (g - g_h)(t') dt',
!>    which vanishes at t = 0 and t = L because the L2 projection preserves the mean.  In the
!>    triangle T containing e, with opposite vertex c and barycentric coordinates lambda_*,
!>        omega = (1 - lambda_c) * W(sigma),  W(sigma) = omega_e(L sigma),
!>        sigma = lambda_b / (lambda_a + lambda_b);
!>    omega is continuous, vanishes on the two other sides of T, is W^{1,inf}, and is zero in
!>    the triangles that have no side on Gamma_a (contributions of two sides of one triangle
!>    add).  lambda_omega = curl omega = (-d omega/dy, d omega/dx) is divergence free.
!>
!> Sign (checked by hand and by the tests):  with the mesh convention nu = (dy, -dx)/L for the
!> direction (dx, dy) from a to b,  lambda_omega . nu = -omega_y nu_1 + omega_x nu_2
!> = grad(omega) . (nu_2, -nu_1) = -grad(omega) . tau,  tau = (dx, dy)/L the unit tangent from a
!> to b.  Along e, omega = omega_e(t), so lambda_omega . nu = -d omega_e/dt = g - g_h, and
!>     lambda_f . nu = lambda_bar . nu + lambda_omega . nu = -g + (g - g_h) = -g_h   on Gamma_a,
!> linear on every side of Gamma_a.  (In the paper's (6.25) the arc length s runs along
!> (nu_2, -nu_1), i.e. against our tau; hence the same formula there reads d omega/ds.)
!>
!> Integrals.  Every one-dimensional integral (the x-integral of f in lambda_bar, the moments
!> int_e g psi_k ds of the projection, the residual integral in omega_e) is computed by the
!> same adaptive Gauss-Legendre scheme: on a panel the 10-point and the 20-point rule are
!> compared; the 20-point value is accepted when they agree to `adapt_rel_tol` times the
!> scale of the whole integral (int |integrand|, or int_e |g| ds for omega_e), otherwise the
!> panel is bisected, at most `adapt_max_depth` times and for at most `adapt_max_panels`
!> panels.  Both Gauss rules leave a strip at each end of a panel unsampled, so the
!> integrand at the two ends is also compared with the extrapolated 20-point interpolant
!> (see `panel`); otherwise a kink hidden in that strip would be accepted silently.
!> Accuracy: for smooth (analytic) integrands one panel, error ~1e-15 relative; with a C^0
!> kink (the catalogue's manufactured P2 source is only C^0 at x = 1/3) bisection down to
!> ~1e-6 of the interval, error <= ~2e-13 relative (measured over 20000 end points; the
!> rule difference can under-estimate a kinked panel's error by a small factor).  When a
!> limit is reached the result is kept and the optional `converged` flags are .false.
!>
!> The point evaluations lambda_bar_at, lambda_omega_at, lambda_f_at are ordinary (impure)
!> functions only because of their optional intent(out) `converged` flag; they have no side
!> effects.  A call of lambda_f_at in a triangle with a Gamma_a side costs one adaptive
!> integral of g - g_h along the side (each value of g an adaptive integral of f): about
!> 32 x 32 evaluations of f for smooth f.
!>
!> To keep omega exactly zero on the two other sides of T, omega_e(t) is integrated from the
!> nearer end of e:  -int_0^t (g - g_h) for t <= L/2,  +int_t^L (g - g_h) for t > L/2; the two
!> agree at t = L/2 up to the quadrature tolerance, so omega_e(0) = omega_e(L) = 0 exactly.
module dualsig_particular_field
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, set_warning, DS_ERR_INPUT, DS_ERR_MESH, &
                            DS_ERR_NUMERIC, DS_WARN_NOT_CONVERGED
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_elements_p1, only: p1_gradients
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: particular_field_t, particular_field_build, particular_field_x_start
  public :: lambda_bar_at, lambda_omega_at, lambda_f_at
  public :: adapt_rel_tol, adapt_max_depth, adapt_max_panels

  !> A panel is accepted when its 10-point and 20-point Gauss values differ by at most
  !> adapt_rel_tol times the scale of the whole integral (about 45 machine epsilons).
  !> For omega_e the scale is int_e |g| ds, not the (much smaller) residual g - g_h.
  real(dp), parameter :: adapt_rel_tol = 1.0e-14_dp
  !> A panel is bisected at most this many times (a panel of the top interval / 2**40).
  integer, parameter :: adapt_max_depth = 40
  !> At most this many panels are evaluated per integral (bounds the cost of hopeless cases).
  integer, parameter :: adapt_max_panels = 2000
  !> Rounding floor: a panel whose rule difference is below roundoff_factor * epsilon times
  !> the panel's integral of |integrand| (plus the propagated error of inner integrals) is
  !> accepted; the rules cannot be compared more finely than their own rounding.
  real(dp), parameter :: roundoff_factor = 20.0_dp
  !> A point with lambda_a + lambda_b <= vertex_guard is the vertex c opposite a Gamma_a side
  !> up to rounding: the gradient of omega has no limit there (it depends on the direction
  !> of approach) and the contribution of that side is set to 0 (a set of measure zero).
  real(dp), parameter :: vertex_guard = 1.0e-14_dp

  !> Gauss-Legendre rules on [-1, 1], positive abscissae and their weights (the rules are
  !> symmetric); 10 points (exact for degree 19) and 20 points (exact for degree 39).
  !> Computed by Newton's method in quadruple precision (cf. dualsig_quadrature's
  !> gauss_legendre) and rounded to 21 digits.
  integer, parameter :: n_low = 10, n_high = 20
  real(dp), parameter :: gl10_x(5) = [ &
    0.148874338981631210885_dp, 0.433395394129247190799_dp, 0.679409568299024406234_dp, &
    0.865063366688984510732_dp, 0.973906528517171720078_dp]
  real(dp), parameter :: gl10_w(5) = [ &
    0.295524224714752870174_dp, 0.269266719309996355091_dp, 0.219086362515982043996_dp, &
    0.149451349150580593146_dp, 0.066671344308688137594_dp]
  real(dp), parameter :: gl20_x(10) = [ &
    0.076526521133497333755_dp, 0.227785851141645078080_dp, 0.373706088715419560673_dp, &
    0.510867001950827098004_dp, 0.636053680726515025453_dp, 0.746331906460150792614_dp, &
    0.839116971822218823395_dp, 0.912234428251325905868_dp, 0.963971927277913791268_dp, &
    0.993128599185094924786_dp]
  real(dp), parameter :: gl20_w(10) = [ &
    0.152753387130725850698_dp, 0.149172986472603746788_dp, 0.142096109318382051329_dp, &
    0.131688638449176626898_dp, 0.118194531961518417312_dp, 0.101930119817240435037_dp, &
    0.083276741576704748725_dp, 0.062672048334109063570_dp, 0.040601429800386941331_dp, &
    0.017614007139152118312_dp]
  !> The full rules, abscissae in increasing order.
  real(dp), parameter :: gl10_full_x(n_low) = [-gl10_x(5:1:-1), gl10_x]
  real(dp), parameter :: gl10_full_w(n_low) = [gl10_w(5:1:-1), gl10_w]
  real(dp), parameter :: gl20_full_x(n_high) = [-gl20_x(10:1:-1), gl20_x]
  real(dp), parameter :: gl20_full_w(n_high) = [gl20_w(10:1:-1), gl20_w]
  !> Barycentric weights of the 20 Gauss-Legendre abscissae, (-1)**k sqrt((1 - x_k**2) w_k)
  !> (Wang & Xiang 2012), and from them the coefficients that extrapolate the degree-19
  !> interpolant of the values at the abscissae to the ends -1 and +1 of the panel.
  real(dp), parameter :: gl20_bary(n_high) = reshape(spread([-1.0_dp, 1.0_dp], 2, n_high / 2), [n_high]) &
                                             * sqrt((1.0_dp - gl20_full_x**2) * gl20_full_w)
  real(dp), parameter :: gl20_extrap_left(n_high) = (gl20_bary / (-1.0_dp - gl20_full_x)) &
                                                    / sum(gl20_bary / (-1.0_dp - gl20_full_x))
  real(dp), parameter :: gl20_extrap_right(n_high) = (gl20_bary / (1.0_dp - gl20_full_x)) &
                                                     / sum(gl20_bary / (1.0_dp - gl20_full_x))

  !> Most breakpoints (abscissae of kinks of f) a scene may declare.
  integer, parameter, public :: max_breaks = 8

  ! kinds of one-dimensional integrands (see integrand_eval)
  integer, parameter :: INT_SOURCE_LINE = 1    !! f(s, y): the x-integral of lambda_bar
  integer, parameter :: INT_EDGE_MOMENTS = 2   !! g(s) (psi_a(s), psi_b(s)) on a side, s = arc length
  integer, parameter :: INT_EDGE_RESIDUAL = 3  !! g(s) - g_h(s) on a side

  !> Description of a one-dimensional integrand (module-private).
  type :: integrand_t
    integer :: kind = 0
    real(dp) :: y = 0.0_dp          !! INT_SOURCE_LINE: the ordinate of the line
    real(dp) :: x_start = 0.0_dp    !! edge kinds: start abscissa of lambda_bar
    real(dp) :: a(2) = 0.0_dp       !! edge kinds: start point of the side
    real(dp) :: b(2) = 0.0_dp       !! edge kinds: end point of the side
    real(dp) :: length = 0.0_dp     !! edge kinds: side length L
    real(dp) :: nu1 = 0.0_dp        !! edge kinds: first component of the outward normal
    real(dp) :: gh(2) = 0.0_dp      !! INT_EDGE_RESIDUAL: g_h at a and at b
    integer :: nbreaks = 0          !! abscissae x where f may have a kink (integrals split there)
    real(dp) :: breaks(max_breaks) = 0.0_dp
  end type integrand_t

  !> The particular field lambda_f = lambda_bar + lambda_omega of a mesh, a set Gamma_a and a
  !> source f.  Built by `particular_field_build`; the components are read-only for callers.
  type :: particular_field_t
    real(dp) :: x_start = 0.0_dp             !! lower limit of the x-integral in lambda_bar
    integer :: nbedge = 0                    !! number of boundary edges of the mesh
    integer :: ntri = 0                      !! number of triangles of the mesh
    logical, allocatable :: is_gamma_a(:)    !! (nbedge) boundary edge j lies in Gamma_a
    !> (2, nbedge) g_h at the start and at the end (bedge_nodes(1:2, j)) of each Gamma_a side,
    !> 0 on the other boundary edges.  lambda_f . nu = -g_h on Gamma_a.
    real(dp), allocatable :: gh(:,:)
    real(dp), allocatable :: g_abs(:)        !! (nbedge) int_e |g| ds (scale of omega_e)
    integer, allocatable :: bedge_local(:,:) !! (3, nbedge) local vertices (a, b, c) in bedge_tri
    integer, allocatable :: tri_ngamma(:)    !! (ntri) number of Gamma_a sides of triangle t
    integer, allocatable :: tri_gamma(:,:)   !! (3, ntri) those boundary edges (first tri_ngamma)
    logical :: converged = .true.            !! every integral of the build met its tolerance
    integer :: nbreaks = 0                   !! known kinks of f in x (split points of the integrals)
    real(dp) :: breaks(max_breaks) = 0.0_dp
  end type particular_field_t

contains

  !> The left edge of the bounding box of the mesh: the x_start the driver passes, so that
  !> every integration path of lambda_bar stays in the bounding box.
  pure real(dp) function particular_field_x_start(mesh) result(x0)
    type(mesh_t), intent(in) :: mesh
    x0 = minval(mesh%xy(1, 1:mesh%nnode))
  end function particular_field_x_start

  !> lambda_bar(x, y) = ( -int_{x_start}^{x} f(t, y) dt, 0 ) of Section 4 (the field with
  !> div lambda_bar + f = 0 used in (4.1)).  f must be defined on the segment between
  !> (x_start, y) and (x, y).  `converged` (optional) is .false. when the adaptive quadrature
  !> stopped at adapt_max_depth or adapt_max_panels.
  function lambda_bar_at(f, x_start, x, y, converged, breaks) result(v)
    class(field_t), intent(in) :: f
    real(dp), intent(in) :: x_start, x, y
    logical, intent(out), optional :: converged
    real(dp), intent(in), optional :: breaks(:)   !! abscissae of kinks of f (split points)
    real(dp) :: v(2)
    real(dp) :: err, br(max_breaks)
    integer :: nb
    logical :: ok
    ok = .true.
    nb = 0
    br = 0.0_dp
    if (present(breaks)) then
      nb = min(size(breaks), max_breaks)
      br(1:nb) = breaks(1:nb)
    end if
    call lambda_bar_1(f, x_start, x, y, v(1), err, ok, nb, br)
    v(2) = 0.0_dp
    if (present(converged)) converged = ok
  end function lambda_bar_at

  !> Build the particular field: g_h on every side of Gamma_a (the L2 projection of
  !> g = -lambda_bar . nu onto P_1 of the side, Section 4), the scales of g and the list of
  !> Gamma_a sides of every triangle.
  !>
  !> mesh: with topology (mesh_build_topology); is_gamma_a(nbedge): the Gamma_a mask of the
  !> boundary edges; x_start: see `particular_field_x_start`; f must be defined on the
  !> bounding box of the mesh.  st: DS_ERR_INPUT / DS_ERR_MESH for bad arguments,
  !> DS_ERR_NUMERIC when g_h is not finite, DS_WARN_NOT_CONVERGED when an integral stopped
  !> at a quadrature limit (the result is kept).
  subroutine particular_field_build(mesh, f, x_start, is_gamma_a, pf, st, breaks)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    real(dp), intent(in) :: x_start
    logical, intent(in) :: is_gamma_a(:)
    type(particular_field_t), intent(out) :: pf
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: breaks(:)   !! abscissae where f may have a kink
    character(len=*), parameter :: who = 'particular_field_build'
    character(len=200) :: buf
    type(integrand_t) :: ig
    real(dp) :: mom(2), abs_int, err
    integer :: j, t, k, n, ja, jb, nbad, ist
    logical :: ok

    if (.not. allocated(mesh%bedge_tri) .or. .not. allocated(mesh%bedge_normal)) then
      call set_error(st, DS_ERR_MESH, who // ': the mesh has no topology (call mesh_build_topology)')
      return
    end if
    if (size(is_gamma_a) /= mesh%nbedge) then
      write (buf, '(a,i0,a,i0,a)') who // ': is_gamma_a has ', size(is_gamma_a), &
        ' entries (expected one per boundary edge, ', mesh%nbedge, ')'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    if (.not. ieee_is_finite(x_start)) then
      call set_error(st, DS_ERR_INPUT, who // ': x_start is not finite')
      return
    end if

    pf%x_start = x_start
    if (present(breaks)) then
      if (size(breaks) > max_breaks) then
        call set_error(st, DS_ERR_INPUT, who // ': more than max_breaks breakpoints')
        return
      end if
      pf%nbreaks = size(breaks)
      pf%breaks(1:pf%nbreaks) = breaks
    end if
    pf%nbedge = mesh%nbedge
    pf%ntri = mesh%ntri
    pf%is_gamma_a = is_gamma_a
    allocate (pf%gh(2, mesh%nbedge), pf%g_abs(mesh%nbedge), pf%bedge_local(3, mesh%nbedge), &
              pf%tri_ngamma(mesh%ntri), pf%tri_gamma(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the particular field', 6 * mesh%nbedge + 4 * mesh%ntri, BYTES_REAL)) return
    pf%gh = 0.0_dp
    pf%g_abs = 0.0_dp
    pf%bedge_local = 0
    pf%tri_ngamma = 0
    pf%tri_gamma = 0
    pf%converged = .true.
    nbad = 0

    do j = 1, mesh%nbedge
      if (.not. is_gamma_a(j)) cycle
      ! local vertices a, b (the side, in the order of bedge_nodes) and c (opposite)
      t = mesh%bedge_tri(j)
      ja = 0
      jb = 0
      do k = 1, 3
        if (mesh%tri(k, t) == mesh%bedge_nodes(1, j)) ja = k
        if (mesh%tri(k, t) == mesh%bedge_nodes(2, j)) jb = k
      end do
      if (ja == 0 .or. jb == 0) then
        write (buf, '(a,i0,a,i0)') who // ': boundary edge ', j, ' is not a side of its triangle ', t
        call set_error(st, DS_ERR_MESH, trim(buf))
        return
      end if
      pf%bedge_local(:, j) = [ja, jb, 6 - ja - jb]
      n = pf%tri_ngamma(t) + 1
      pf%tri_ngamma(t) = n
      pf%tri_gamma(n, t) = j

      ! g = -lambda_bar . nu = -lambda_bar_1 nu_1 vanishes identically on sides with nu_1 = 0
      if (mesh%bedge_normal(1, j) == 0.0_dp) cycle
      ig = edge_integrand(pf, mesh, j, INT_EDGE_MOMENTS)
      ok = .true.
      call split_integral(f, ig, 0.0_dp, mesh%bedge_length(j), 0.0_dp, mom, abs_int, err, ok)
      ! L2(e) projection onto P_1(e): (L/6) [[2,1],[1,2]] gh = (int g psi_a, int g psi_b),
      ! inverse (2/L) [[2,-1],[-1,2]]
      pf%gh(:, j) = (2.0_dp / mesh%bedge_length(j)) * &
                    [2.0_dp * mom(1) - mom(2), 2.0_dp * mom(2) - mom(1)]
      pf%g_abs(j) = abs_int          ! int_e (|g psi_a| + |g psi_b|) ds = int_e |g| ds
      if (.not. all(ieee_is_finite(pf%gh(:, j)))) then
        write (buf, '(a,i0,a)') who // ': g_h on boundary edge ', j, &
          ' is not finite (is f finite on the bounding box of the mesh?)'
        call set_error(st, DS_ERR_NUMERIC, trim(buf))
        return
      end if
      if (.not. ok) then
        pf%converged = .false.
        nbad = nbad + 1
      end if
    end do
    if (nbad > 0) then
      write (buf, '(a,i0,a)') who // ': the projection integrals of ', nbad, &
        ' Gamma_a edge(s) stopped at the quadrature limits (tolerance not met)'
      call set_warning(st, DS_WARN_NOT_CONVERGED, trim(buf))
    end if
  end subroutine particular_field_build

  !> The correction lambda_omega = curl omega = (-d omega/dy, d omega/dx) at (x, y) in
  !> triangle t (Remark 6.5, (6.25), variant): the sum over the Gamma_a sides of t of the
  !> curl of omega_e extended into t; 0 in triangles without a Gamma_a side.
  !> Precondition: (x, y) lies in triangle t (the barycentric parameter sigma is clamped to
  !> [0, 1], so points within rounding outside t are harmless).
  function lambda_omega_at(pf, mesh, f, t, x, y, converged) result(v)
    type(particular_field_t), intent(in) :: pf
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: t
    real(dp), intent(in) :: x, y
    logical, intent(out), optional :: converged
    real(dp) :: v(2)
    real(dp) :: xyt(2, 3), grad(2, 3), area, p(2), pc(2), la, lb, s, sigma, w, dw, gomega(2)
    integer :: n, j, ia, ib, ic
    logical :: ok

    v = 0.0_dp
    ok = .true.
    if (pf%tri_ngamma(t) > 0) then
      xyt = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xyt, grad, area)
      p = [x, y]
      do n = 1, pf%tri_ngamma(t)
        j = pf%tri_gamma(n, t)
        if (mesh%bedge_normal(1, j) == 0.0_dp) cycle        ! g = g_h = 0: omega_e = 0
        ia = pf%bedge_local(1, j)
        ib = pf%bedge_local(2, j)
        ic = pf%bedge_local(3, j)
        ! barycentrics of a and b measured from c (both vanish at c exactly)
        pc = p - xyt(:, ic)
        la = dot_product(grad(:, ia), pc)
        lb = dot_product(grad(:, ib), pc)
        s = la + lb                                         ! = 1 - lambda_c
        if (s <= vertex_guard) cycle
        sigma = min(1.0_dp, max(0.0_dp, lb / s))
        call omega_edge(pf, mesh, f, j, sigma, w, dw, ok)
        ! omega = s W(sigma);  grad omega = W grad s + s W'(sigma) grad sigma, with
        ! s grad sigma = (lambda_a grad lambda_b - lambda_b grad lambda_a) / s
        !              = (1 - sigma) grad lambda_b - sigma grad lambda_a   (bounded near c)
        gomega = w * (grad(:, ia) + grad(:, ib)) &
               + dw * ((1.0_dp - sigma) * grad(:, ib) - sigma * grad(:, ia))
        v = v + [-gomega(2), gomega(1)]
      end do
    end if
    if (present(converged)) converged = ok
  end function lambda_omega_at

  !> The particular field lambda_f = lambda_bar + lambda_omega at (x, y) in triangle t:
  !> div lambda_f + f = 0 in Omega and lambda_f . nu = -g_h (linear) on every side of Gamma_a,
  !> so that lambda_f + q^h lies in U_2 for every q^h in K_h (Section 4, Remark 6.5).
  function lambda_f_at(pf, mesh, f, t, x, y, converged) result(v)
    type(particular_field_t), intent(in) :: pf
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: t
    real(dp), intent(in) :: x, y
    logical, intent(out), optional :: converged
    real(dp) :: v(2)
    logical :: ok_bar, ok_omega
    v = lambda_bar_at(f, pf%x_start, x, y, ok_bar, pf%breaks(1:pf%nbreaks)) + &
        lambda_omega_at(pf, mesh, f, t, x, y, ok_omega)
    if (present(converged)) converged = ok_bar .and. ok_omega
  end function lambda_f_at

  ! ------------------------------------------------------------------ internals

  !> lambda_bar_1 = -int_{x_start}^{x} f(t, y) dt, and an estimate err of its absolute error
  !> (including rounding); ok is set to .false. when a quadrature limit was reached.
  recursive subroutine lambda_bar_1(f, x_start, x, y, val, err, ok, nbreaks, breaks)
    class(field_t), intent(in) :: f
    real(dp), intent(in) :: x_start, x, y
    real(dp), intent(out) :: val, err
    logical, intent(inout) :: ok
    integer, intent(in) :: nbreaks
    real(dp), intent(in) :: breaks(max_breaks)
    type(integrand_t) :: ig
    real(dp) :: res(2), abs_int
    ig%kind = INT_SOURCE_LINE
    ig%y = y
    ig%nbreaks = nbreaks
    ig%breaks = breaks
    call split_integral(f, ig, x_start, x, 0.0_dp, res, abs_int, err, ok)
    val = -res(1)
  end subroutine lambda_bar_1

  !> The integrand description of boundary edge j (a side of Gamma_a).
  pure function edge_integrand(pf, mesh, j, kind) result(ig)
    type(particular_field_t), intent(in) :: pf
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: j, kind
    type(integrand_t) :: ig
    ig%kind = kind
    ig%x_start = pf%x_start
    ig%a = mesh%xy(:, mesh%bedge_nodes(1, j))
    ig%b = mesh%xy(:, mesh%bedge_nodes(2, j))
    ig%length = mesh%bedge_length(j)
    ig%nu1 = mesh%bedge_normal(1, j)
    ig%gh = pf%gh(:, j)
    ig%nbreaks = pf%nbreaks
    ig%breaks = pf%breaks
  end function edge_integrand

  !> W(sigma) = omega_e(L sigma) and dW/dsigma = -L (g - g_h)(L sigma) on Gamma_a side j,
  !> omega_e(t) = -int_0^t (g - g_h) (the variant of (6.25)), integrated from the nearer end.
  subroutine omega_edge(pf, mesh, f, j, sigma, w, dw, ok)
    type(particular_field_t), intent(in) :: pf
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: j
    real(dp), intent(in) :: sigma
    real(dp), intent(out) :: w, dw
    logical, intent(inout) :: ok
    type(integrand_t) :: ig
    real(dp) :: tt, res(2), abs_int, err, r(2), noise
    ig = edge_integrand(pf, mesh, j, INT_EDGE_RESIDUAL)
    tt = sigma * ig%length
    if (sigma <= 0.5_dp) then
      call split_integral(f, ig, 0.0_dp, tt, pf%g_abs(j), res, abs_int, err, ok)
      w = -res(1)
    else
      call split_integral(f, ig, tt, ig%length, pf%g_abs(j), res, abs_int, err, ok)
      w = res(1)
    end if
    call integrand_eval(f, ig, tt, r, noise, ok)
    dw = -ig%length * r(1)
  end subroutine omega_edge

  !> The integrand of kind ig%kind at the abscissa s (x for INT_SOURCE_LINE, arc length from
  !> the start of the side for the edge kinds), and a bound `noise` of its absolute error
  !> (nonzero when it contains an inner integral).
  recursive subroutine integrand_eval(f, ig, s, v, noise, ok)
    class(field_t), intent(in) :: f
    type(integrand_t), intent(in) :: ig
    real(dp), intent(in) :: s
    real(dp), intent(out) :: v(2), noise
    logical, intent(inout) :: ok
    real(dp) :: r, p(2), lb1, err, g
    select case (ig%kind)
    case (INT_SOURCE_LINE)
      v = [f%value(s, ig%y), 0.0_dp]
      noise = 0.0_dp
    case default
      r = s / ig%length
      p = (1.0_dp - r) * ig%a + r * ig%b
      call lambda_bar_1(f, ig%x_start, p(1), p(2), lb1, err, ok, ig%nbreaks, ig%breaks)
      g = -lb1 * ig%nu1                        ! g = -lambda_bar . nu, lambda_bar_2 = 0
      noise = err * abs(ig%nu1)
      if (ig%kind == INT_EDGE_MOMENTS) then
        v = g * [1.0_dp - r, r]                ! psi_a, psi_b: the P_1(e) basis
      else
        v = [g - ((1.0_dp - r) * ig%gh(1) + r * ig%gh(2)), 0.0_dp]
      end if
    end select
  end subroutine integrand_eval

  !> The integral of ig over [lo, hi] as a sum of adaptive integrals over the pieces between
  !> the breakpoints of f that fall inside: abscissae x = breaks(k) directly for the source
  !> line, and the arc lengths where the side crosses x = breaks(k) for the edge kinds.
  !> Splitting at a kink keeps every piece smooth, so the adaptive rule needs no bisection
  !> cascade there.
  recursive subroutine split_integral(f, ig, lo, hi, scale_in, val, abs_int, err, ok)
    class(field_t), intent(in) :: f
    type(integrand_t), intent(in) :: ig
    real(dp), intent(in) :: lo, hi, scale_in
    real(dp), intent(out) :: val(2), abs_int, err
    logical, intent(inout) :: ok
    real(dp) :: cuts(max_breaks + 2), s, tmp, v(2), a_int, e
    integer :: k, n, m
    n = 1
    cuts(1) = lo
    do k = 1, ig%nbreaks
      if (ig%kind == INT_SOURCE_LINE) then
        s = ig%breaks(k)
      else if (ig%b(1) /= ig%a(1)) then
        s = ig%length * (ig%breaks(k) - ig%a(1)) / (ig%b(1) - ig%a(1))
      else
        cycle
      end if
      if ((s - lo) * (s - hi) < 0.0_dp) then      ! strictly inside
        n = n + 1
        cuts(n) = s
      end if
    end do
    ! order the cuts from lo towards hi
    do k = 2, n
      tmp = cuts(k)
      m = k - 1
      do while (m >= 2)
        if ((cuts(m) - tmp) * (hi - lo) <= 0.0_dp) exit
        cuts(m + 1) = cuts(m)
        m = m - 1
      end do
      cuts(m + 1) = tmp
    end do
    n = n + 1
    cuts(n) = hi
    val = 0.0_dp
    abs_int = 0.0_dp
    err = 0.0_dp
    do k = 1, n - 1
      call adaptive_integral(f, ig, cuts(k), cuts(k + 1), scale_in, v, a_int, e, ok)
      val = val + v
      abs_int = abs_int + a_int
      err = err + e
    end do
  end subroutine split_integral

  !> Adaptive Gauss-Legendre integral of the (two-component) integrand ig over [lo, hi]
  !> (hi < lo gives the signed integral).  A panel's 20-point value is accepted when its
  !> error estimate (the difference from the 10-point value, or the endpoint-gap estimate
  !> of `panel` if larger) is at most adapt_rel_tol * scale, scale = max(scale_in,
  !> int_lo^hi (|v_1| + |v_2|) by the 20-point rule on the whole interval), or at most its
  !> rounding floor; otherwise the panel is bisected (depth-first, explicit stack).
  !> abs_int: that 20-point estimate of int (|v_1| + |v_2|) on [lo, hi]; err: the sum of the
  !> error estimates of the accepted panels plus their rounding floors (an estimate of the
  !> error of the result); ok is set to .false. when a depth or panel limit was hit.
  recursive subroutine adaptive_integral(f, ig, lo, hi, scale_in, val, abs_int, err, ok)
    class(field_t), intent(in) :: f
    type(integrand_t), intent(in) :: ig
    real(dp), intent(in) :: lo, hi, scale_in
    real(dp), intent(out) :: val(2), abs_int, err
    logical, intent(inout) :: ok
    real(dp) :: sa(adapt_max_depth + 1), sb(adapt_max_depth + 1)
    integer :: sdepth(adapt_max_depth + 1)
    real(dp) :: a, b, i_high(2), loc_abs, noise, tol, diff, floor_
    integer :: top, depth, npanel

    val = 0.0_dp
    abs_int = 0.0_dp
    err = 0.0_dp
    if (hi == lo) return
    call panel(lo, hi, i_high, diff, loc_abs, noise, ok)
    abs_int = loc_abs
    tol = adapt_rel_tol * max(scale_in, loc_abs)
    npanel = 1                       ! panels evaluated so far (the whole interval)
    top = 1
    sa(1) = lo
    sb(1) = hi
    sdepth(1) = 0
    do while (top > 0)
      a = sa(top)
      b = sb(top)
      depth = sdepth(top)
      top = top - 1
      if (depth > 0) then            ! the whole interval (depth 0) is evaluated above
        call panel(a, b, i_high, diff, loc_abs, noise, ok)
        npanel = npanel + 1
      end if
      floor_ = roundoff_factor * epsilon(1.0_dp) * loc_abs + 2.0_dp * abs(b - a) * noise
      if (diff <= max(tol, floor_) .or. depth >= adapt_max_depth .or. npanel >= adapt_max_panels) then
        if (diff > max(tol, floor_)) ok = .false.
        val = val + i_high
        err = err + diff + floor_
      else
        ! bisect: push the right half first so that the left half is processed next
        sa(top + 1) = 0.5_dp * (a + b)
        sb(top + 1) = b
        sa(top + 2) = a
        sb(top + 2) = 0.5_dp * (a + b)
        sdepth(top + 1:top + 2) = depth + 1
        top = top + 2
      end if
    end do

  contains

    !> On [pa, pb]: the 20-point value r_high, the error estimate r_est = max(|20-point -
    !> 10-point|, endpoint-gap estimate), the 20-point int (|v_1| + |v_2|) and the largest
    !> noise of the integrand values.
    !>
    !> The endpoint gap: both Gauss rules leave the strip between an end of the panel and its
    !> outermost node (0.34 % of the panel for 20 points) unsampled, so a kink of the
    !> integrand inside that strip is invisible to both and they may agree exactly.  The
    !> integrand at the two ends is therefore compared with the extrapolation of the
    !> 20-point interpolant; a kink at distance d <= gap from the end with slope jump J shifts
    !> the end value by about J d and the integral by J d**2 / 2 <= |shift| * gap / 2.
    recursive subroutine panel(pa, pb, r_high, r_est, r_abs, r_noise, p_ok)
      real(dp), intent(in) :: pa, pb
      real(dp), intent(out) :: r_high(2), r_est, r_abs, r_noise
      logical, intent(inout) :: p_ok
      real(dp) :: mid, half, v(2), nz, r_low(2), v20(2, n_high), ends(2, 2), gap
      integer :: k
      mid = 0.5_dp * (pa + pb)
      half = 0.5_dp * (pb - pa)
      r_low = 0.0_dp
      r_noise = 0.0_dp
      do k = 1, n_low
        call integrand_eval(f, ig, mid + half * gl10_full_x(k), v, nz, p_ok)
        r_low = r_low + gl10_full_w(k) * v
        r_noise = max(r_noise, nz)
      end do
      do k = 1, n_high
        call integrand_eval(f, ig, mid + half * gl20_full_x(k), v20(:, k), nz, p_ok)
        r_noise = max(r_noise, nz)
      end do
      call integrand_eval(f, ig, pa, ends(:, 1), nz, p_ok)
      r_noise = max(r_noise, nz)
      call integrand_eval(f, ig, pb, ends(:, 2), nz, p_ok)
      r_noise = max(r_noise, nz)
      r_low = half * r_low
      r_high = half * matmul(v20, gl20_full_w)
      r_abs = abs(half) * dot_product(sum(abs(v20), dim=1), gl20_full_w)
      gap = abs(half) * (1.0_dp - gl20_x(n_high / 2))
      r_est = max(maxval(abs(r_high - r_low)), &
                  0.5_dp * gap * maxval(abs(ends(:, 1) - matmul(v20, gl20_extrap_left))), &
                  0.5_dp * gap * maxval(abs(ends(:, 2) - matmul(v20, gl20_extrap_right))))
    end subroutine panel
  end subroutine adaptive_integral
end module dualsig_particular_field
