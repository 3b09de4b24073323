!> Enclosures of a compiled expression (dualsig_expression) over a triangle: the range of
!> f(x, y) on the closed triangle, by interval arithmetic on the same bytecode, with the
!> gradient carried along as intervals (interval dual numbers).
!>
!> expression_range(expr, tri, lo, hi): lo <= f <= hi at every point of the triangle where f
!> is defined.  Two enclosures are intersected:
!> - the natural one: every instruction applied to intervals on the triangle's bounding box
!>   (x -> [x_lo, x_hi], ...);
!> - the centred (mean-value) form f(m) + G . (x - m), m the centroid and G the enclosure of
!>   the gradient on the box, over the triangle itself: for every g in G the linear part has
!>   its extremes at the vertices.  It holds where f is Lipschitz on the box (abs, min and max
!>   with their generalised gradients), and it is of second order in the size of the
!>   triangle where the natural one is only of first order (x*(1-x) near its maximum).
!> Comparisons, and, or, not and the condition of an `if` are decided by the same centred
!> form of their operands on the triangle, so a jump along a line that only touches the
!> triangle (x + y < 1 on a triangle with a side on x + y = 1, shrunk by a rounding margin)
!> is decided; one that crosses it contributes both branches (and no centred form).
!> Where an operation may leave its domain on the box (log, sqrt, asin, acos of an interval
!> reaching outside it, a division by an interval containing 0, a non-integer power of a
!> negative number) the enclosure is the whole real line (lo = -Inf, hi = +Inf): no claim.
!> Invariant: where the value at a point of the box may be NaN (an operation outside its
!> domain, 0 * Inf, Inf - Inf, Inf / Inf, sin or cos of an overflow), its enclosure is the
!> whole line, and every operation but a comparison (and, or, not, the condition of an if)
!> maps a whole-line operand to the whole line: a comparison, min, max or a product by 0 at
!> the points can turn a NaN into a finite value, which the enclosure must then still hold
!> (min(x, NaN) is x at the points; 0 * [no claim] is not [0, 0]).  A bound that may be
!> +Inf or -Inf at a point is infinite in the enclosure.
!>
!> Infinite and NaN intermediate values are part of the arithmetic (1/[0, 1], exp of a
!> large bound): floating-point traps are disarmed while an enclosure is computed and the
!> caller's floating-point status is restored after it.
!>
!> Rounding: every bound computed is moved outwards by range_rel_widen of its size plus the
!> smallest normal number, more than the error of one IEEE operation or of libm's elementary
!> functions (within a few ulps), so the enclosures hold for the computed intervals' exact
!> values.  sin and cos test their extrema with the same margin.
!>
!> Used by the load data (dualsig_load_data through field_t%range_on_triangle) to find
!> features of f that the cubature's points miss (a strip or a spike between them).
module dualsig_expression_range
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_is_finite, ieee_value, ieee_positive_inf
  use, intrinsic :: ieee_exceptions, only: ieee_status_type, ieee_get_status, ieee_set_status, &
                                           ieee_usual, ieee_underflow, ieee_set_halting_mode
  use dualsig_kinds, only: dp, pi
  use dualsig_expression, only: expression_t, OP_CONST, OP_X, OP_Y, OP_NEG, OP_SQR, OP_POWC, OP_NOT, &
    OP_SIN, OP_COS, OP_TAN, OP_ASIN, OP_ACOS, OP_ATAN, OP_EXP, OP_LOG, OP_LOG10, OP_SQRT, OP_ABS, OP_SINH, &
    OP_COSH, OP_TANH, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW, OP_ATAN2, OP_MIN, OP_MAX, OP_LT, OP_LE, &
    OP_GT, OP_GE, OP_EQ, OP_NE, OP_AND, OP_OR, OP_IF, OP_ELSE, OP_END
  implicit none
  private

  public :: expression_range

  !> Relative outward widening of every computed bound (4 ulps).
  real(dp), parameter :: range_rel_widen = 4.0_dp * epsilon(1.0_dp)

  !> An interval dual number: the value's enclosure on the box, and where smooth the
  !> enclosures of the gradient on the box and of the value at the triangle's centroid.
  type :: ivd_t
    real(dp) :: v(2) = 0.0_dp
    real(dp) :: gx(2) = 0.0_dp, gy(2) = 0.0_dp
    real(dp) :: c(2) = 0.0_dp       !! the value at the centroid m (where smooth)
    logical :: smooth = .true.      !! f Lipschitz on the box, gx, gy enclose its gradient
  end type ivd_t

  !> The triangle, its bounding box and its centroid.
  type :: geometry_t
    real(dp) :: tri(2, 3) = 0.0_dp
    real(dp) :: box(2, 2) = 0.0_dp   !! box(:, 1) = [x_lo, x_hi], box(:, 2) = [y_lo, y_hi]
    real(dp) :: m(2) = 0.0_dp
  end type geometry_t

contains

  !> lo <= f(x, y) <= hi on the closed triangle tri(:, 1:3) (the whole real line when no
  !> finite enclosure is found).  enough (optional): an interval that suffices the caller;
  !> the gradient pass is not made when the natural enclosure on the bounding box lies in it.
  !> rough (optional): f may have a kink or a jump inside the triangle: the argument of an
  !> abs, the difference of the arguments of a min or max, or a comparison (an if's
  !> condition) is not decided on it by the centred form (the gradient pass is then always
  !> made).  A cubature's agreement proves nothing there (a kink between a line of its
  !> subdivision and its nearest points is seen as linear by a piece and its children).
  subroutine expression_range(expr, tri, lo, hi, enough, rough)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: tri(2, 3)
    real(dp), intent(out) :: lo, hi
    real(dp), intent(in), optional :: enough(2)
    logical, intent(out), optional :: rough
    type(geometry_t) :: g
    type(ivd_t) :: whole
    real(dp) :: r(2)
    logical :: kinks
    type(ieee_status_type) :: saved
    if (present(rough)) rough = .false.
    if (expr%n == 0) then
      lo = 0.0_dp
      hi = 0.0_dp
      return
    end if
    g%tri = tri
    g%box(:, 1) = [minval(tri(1, :)), maxval(tri(1, :))]
    g%box(:, 2) = [minval(tri(2, :)), maxval(tri(2, :))]
    g%m = sum(tri, dim=2) / 3.0_dp
    g%m = min(max(g%m, g%box(1, :)), g%box(2, :))       ! in the box despite rounding
    call ieee_get_status(saved)
    call ieee_set_halting_mode(ieee_usual, .false.)
    call ieee_set_halting_mode(ieee_underflow, .false.)
    r = entire_iv()
    kinks = .false.
    ! the natural enclosure on the box alone first (no gradient) when one within enough suffices
    if (present(enough) .and. .not. present(rough)) then
      whole = run_segment(expr, 1, expr%n, g, .false., kinks)
      r = whole%v
    end if
    if (.not. present(enough) .or. present(rough)) then
      whole = run_segment(expr, 1, expr%n, g, .true., kinks)
      r = tri_range(whole, g)
    else if (.not. (r(1) >= enough(1) .and. r(2) <= enough(2))) then
      whole = run_segment(expr, 1, expr%n, g, .true., kinks)
      r = tri_range(whole, g)
    end if
    ! f not Lipschitz on the box (an infinite derivative: sqrt(u) where u reaches 0, so
    ! sqrt((x - c)**2) = abs(x - c)) is rough too
    if (present(rough)) rough = kinks .or. .not. (whole%smooth .and. all(ieee_is_finite([whole%gx, whole%gy])))
    call ieee_set_status(saved)
    lo = r(1)
    hi = r(2)
    if (ieee_is_nan(lo) .or. ieee_is_nan(hi) .or. lo > hi) call entire(lo, hi)
  end subroutine expression_range

  !> The enclosure of q on the triangle: q%v (on the box) intersected, where q is smooth,
  !> with the centred form q(m) + G . (x - m).  For each g in G the linear part has its
  !> extremes at the vertices, so its range on the triangle is the hull of G . (v - m) over
  !> the three vertices v (mean-value theorem, Clarke's for the Lipschitz abs, min, max; the
  !> segment from m to x lies in the triangle, inside the box where G holds).
  pure function tri_range(q, g) result(r)
    type(ivd_t), intent(in) :: q
    type(geometry_t), intent(in) :: g
    real(dp) :: r(2), lin(2), e(2)
    integer :: k
    r = q%v
    if (.not. q%smooth) return
    if (.not. all(ieee_is_finite([q%gx, q%gy, q%c]))) return
    lin = [huge(1.0_dp), -huge(1.0_dp)]
    do k = 1, 3
      e = iv_add(iv_mul(q%gx, iv_sub([g%tri(1, k), g%tri(1, k)], [g%m(1), g%m(1)])), &
                 iv_mul(q%gy, iv_sub([g%tri(2, k), g%tri(2, k)], [g%m(2), g%m(2)])))
      lin = [min(lin(1), e(1)), max(lin(2), e(2))]
    end do
    e = iv_add(q%c, lin)
    r = [max(r(1), e(1)), min(r(2), e(2))]
    if (.not. r(1) <= r(2)) r = q%v
  end function tri_range

  !> The enclosure of the instructions pc0..pc1 (a whole expression or a branch of an if);
  !> grad: the gradients and centroid values wanted (else every value is marked not smooth).
  recursive function run_segment(expr, pc0, pc1, g, grad, kinks) result(r)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    type(geometry_t), intent(in) :: g
    logical, intent(in) :: grad
    logical, intent(inout) :: kinks        !! set where f may kink or jump inside the triangle
    type(ivd_t) :: r
    type(ivd_t) :: s(max(expr%depth, 1)), a, b
    real(dp) :: k
    integer :: pc, t, op, pelse, pend
    t = 0
    pc = pc0
    do while (pc <= pc1)
      op = expr%code(1, pc)
      select case (op)
      case (OP_CONST)
        t = t + 1
        k = expr%consts(expr%code(2, pc))
        s(t) = ivd_t(v=[k, k], c=[k, k])
      case (OP_X)
        t = t + 1
        s(t) = ivd_t(v=g%box(:, 1), gx=[1.0_dp, 1.0_dp], c=[g%m(1), g%m(1)], smooth=grad)
      case (OP_Y)
        t = t + 1
        s(t) = ivd_t(v=g%box(:, 2), gy=[1.0_dp, 1.0_dp], c=[g%m(2), g%m(2)], smooth=grad)
      case (OP_POWC)
        s(t) = ivd_powc(s(t), expr%consts(expr%code(2, pc)))
      case (OP_IF)
        pelse = expr%code(2, pc)
        pend = expr%code(2, pelse)
        select case (truth(tri_range(s(t), g)))
        case (1)
          s(t) = run_segment(expr, pc + 1, pelse - 1, g, grad, kinks)
        case (0)
          s(t) = run_segment(expr, pelse + 1, pend - 1, g, grad, kinks)
        case default
          kinks = .true.
          a = run_segment(expr, pc + 1, pelse - 1, g, grad, kinks)
          b = run_segment(expr, pelse + 1, pend - 1, g, grad, kinks)
          s(t) = ivd_t(v=[min(a%v(1), b%v(1)), max(a%v(2), b%v(2))], smooth=.false.)
        end select
        pc = pend
      case (OP_ELSE, OP_END)
      case (OP_NOT)
        s(t) = logical_result(1 - truth(tri_range(s(t), g)))
      case default
        if (op >= 40 .and. op < 60) then
          t = t - 1
          if (op == OP_MIN .or. op == OP_MAX) then
            if (straddles(tri_range(ivd_arith(OP_SUB, s(t), s(t + 1)), g))) kinks = .true.
          end if
          s(t) = ivd_binary(op, s(t), s(t + 1), g)
          if (op >= OP_LT .and. op <= OP_OR .and. s(t)%v(1) < s(t)%v(2)) kinks = .true.   ! undecided
        else
          if (op == OP_ABS) then
            if (straddles(tri_range(s(t), g))) kinks = .true.
          end if
          s(t) = ivd_unary(op, s(t))
        end if
      end select
      pc = pc + 1
    end do
    r = s(1)
    if (any(ieee_is_nan(r%v))) r = ivd_t(v=entire_iv(), smooth=.false.)
    if (.not. all(ieee_is_finite([r%gx, r%gy]))) r%smooth = .false.
  end function run_segment

  ! ------------------------------------------------------------------ interval dual numbers

  !> The enclosure of u(a) for a unary operation u (not NOT) and an interval a.
  pure function unary_value(op, a) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    select case (op)
    case (OP_NEG); r = [-a(2), -a(1)]
    case (OP_SQR); r = iv_sqr(a)
    case (OP_SIN); r = iv_sin(a)
    case (OP_COS); r = iv_sin(iv_add(a, [0.5_dp * pi, 0.5_dp * pi]))
    case (OP_TAN); r = iv_tan(a)
    case (OP_ASIN, OP_ACOS); r = iv_arc(op, a)
    case (OP_ATAN, OP_EXP, OP_SINH, OP_TANH); r = iv_mono(op, a)
    case (OP_LOG); r = iv_log(a, 1.0_dp)
    case (OP_LOG10); r = iv_log(a, 1.0_dp / log(10.0_dp))
    case (OP_SQRT); r = iv_sqrt(a)
    case (OP_ABS); r = iv_abs(a)
    case (OP_COSH); r = iv_cosh(a)
    case default; r = entire_iv()
    end select
  end function unary_value

  !> A unary operation (not NOT): the value's enclosure, and where a is smooth the value at
  !> the centroid and the gradient's enclosure by the chain rule u'(A) dA.
  pure function ivd_unary(op, a) result(r)
    integer, intent(in) :: op
    type(ivd_t), intent(in) :: a
    type(ivd_t) :: r
    real(dp) :: d(2)
    if (no_claim(a%v)) then                   ! a NaN at a point stays one (the invariant)
      r = no_claim_ivd()
      return
    end if
    r%smooth = a%smooth
    r%v = unary_value(op, a%v)
    if (.not. r%smooth) return                ! no gradient wanted (or none exists)
    r%c = unary_value(op, a%c)
    select case (op)
    case (OP_NEG); d = [-1.0_dp, -1.0_dp]
    case (OP_SQR); d = iv_scale(2.0_dp, a%v)
    case (OP_SIN); d = iv_sin(iv_add(a%v, [0.5_dp * pi, 0.5_dp * pi]))
    case (OP_COS); d = iv_scale(-1.0_dp, iv_sin(a%v))
    case (OP_TAN); d = iv_add([1.0_dp, 1.0_dp], iv_sqr(r%v))
    case (OP_ASIN, OP_ACOS)
      d = iv_div([1.0_dp, 1.0_dp], iv_sqrt(iv_sub([1.0_dp, 1.0_dp], iv_sqr(a%v))))
      if (op == OP_ACOS) d = iv_scale(-1.0_dp, d)
    case (OP_ATAN); d = iv_div([1.0_dp, 1.0_dp], iv_add([1.0_dp, 1.0_dp], iv_sqr(a%v)))
    case (OP_EXP); d = r%v
    case (OP_LOG); d = iv_div([1.0_dp, 1.0_dp], a%v)
    case (OP_LOG10); d = iv_div([1.0_dp, 1.0_dp], iv_scale(log(10.0_dp), a%v))
    case (OP_SQRT); d = iv_div([0.5_dp, 0.5_dp], r%v)
    case (OP_ABS)
      d = [-1.0_dp, 1.0_dp]
      if (a%v(1) >= 0.0_dp) d = [1.0_dp, 1.0_dp]
      if (a%v(2) <= 0.0_dp) d = [-1.0_dp, -1.0_dp]
    case (OP_SINH); d = iv_cosh(a%v)
    case (OP_COSH); d = iv_mono(OP_SINH, a%v)
    case (OP_TANH); d = iv_sub([1.0_dp, 1.0_dp], iv_sqr(r%v))
    case default
      r%smooth = .false.
      return
    end select
    r%gx = iv_mul(d, a%gx)
    r%gy = iv_mul(d, a%gy)
  end function ivd_unary

  !> a**c for a constant c (OP_POWC).
  pure function ivd_powc(a, c) result(r)
    type(ivd_t), intent(in) :: a
    real(dp), intent(in) :: c
    type(ivd_t) :: r
    real(dp) :: d(2)
    if (no_claim(a%v)) then
      r = no_claim_ivd()
      return
    end if
    r%smooth = a%smooth
    r%v = iv_powc(a%v, c)
    if (.not. r%smooth) return
    r%c = iv_powc(a%c, c)
    d = iv_scale(c, iv_powc(a%v, c - 1.0_dp))
    if (c == 0.0_dp) d = [0.0_dp, 0.0_dp]
    r%gx = iv_mul(d, a%gx)
    r%gy = iv_mul(d, a%gy)
  end function ivd_powc

  !> A binary operation a op b; comparisons, and, or decided on the triangle of g.
  pure function ivd_binary(op, a, b, g) result(r)
    integer, intent(in) :: op
    type(ivd_t), intent(in) :: a, b
    type(geometry_t), intent(in) :: g
    type(ivd_t) :: r
    r%smooth = a%smooth .and. b%smooth
    if (op < OP_LT .or. op > OP_OR) then     ! not a comparison, and, or: NaN in, NaN out
      if (no_claim(a%v) .or. no_claim(b%v)) then
        r = no_claim_ivd()
        return
      end if
    end if
    select case (op)
    case (OP_ADD, OP_SUB, OP_MUL, OP_DIV)
      r = ivd_arith(op, a, b)
    case (OP_POW)
      r = ivd_pow(a, b)
    case (OP_ATAN2)
      r = ivd_atan2(a, b)
    case (OP_MIN)
      if (a%v(2) <= b%v(1)) then
        r = a                                 ! a <= b on the whole box
      else if (b%v(2) < a%v(1)) then
        r = b
      else
        r = hull(a, b, [min(a%v(1), b%v(1)), min(a%v(2), b%v(2))], [min(a%c(1), b%c(1)), min(a%c(2), b%c(2))])
      end if
    case (OP_MAX)
      if (a%v(1) >= b%v(2)) then
        r = a
      else if (b%v(1) > a%v(2)) then
        r = b
      else
        r = hull(a, b, [max(a%v(1), b%v(1)), max(a%v(2), b%v(2))], [max(a%c(1), b%c(1)), max(a%c(2), b%c(2))])
      end if
    case (OP_AND, OP_OR)
      r = logical_result(compare(op, tri_range(a, g), tri_range(b, g)))
    case default
      ! comparisons: the sign of a - b on the triangle (a jump where undecided)
      r = logical_result(compare(op, tri_range(ivd_arith(OP_SUB, a, b), g), [0.0_dp, 0.0_dp]))
    end select
  end function ivd_binary

  !> a + b, a - b, a * b, a / b: the values and, where both are smooth, the centroid values
  !> and the gradients.
  pure function ivd_arith(op, a, b) result(r)
    integer, intent(in) :: op
    type(ivd_t), intent(in) :: a, b
    type(ivd_t) :: r
    r%smooth = a%smooth .and. b%smooth
    r%v = arith_value(op, a%v, b%v)
    if (.not. r%smooth) return
    r%c = arith_value(op, a%c, b%c)
    select case (op)
    case (OP_ADD)
      r%gx = iv_add(a%gx, b%gx)
      r%gy = iv_add(a%gy, b%gy)
    case (OP_SUB)
      r%gx = iv_sub(a%gx, b%gx)
      r%gy = iv_sub(a%gy, b%gy)
    case (OP_MUL)
      r%gx = iv_add(iv_mul(a%gx, b%v), iv_mul(a%v, b%gx))
      r%gy = iv_add(iv_mul(a%gy, b%v), iv_mul(a%v, b%gy))
    case (OP_DIV)
      ! (a/b)' = (a' - (a/b) b') / b
      r%gx = iv_div(iv_sub(a%gx, iv_mul(r%v, b%gx)), b%v)
      r%gy = iv_div(iv_sub(a%gy, iv_mul(r%v, b%gy)), b%v)
    end select
  end function ivd_arith

  !> The enclosure of a op b for op = +, -, *, / and intervals a, b.
  pure function arith_value(op, a, b) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2)
    select case (op)
    case (OP_ADD); r = iv_add(a, b)
    case (OP_SUB); r = iv_sub(a, b)
    case (OP_MUL); r = iv_mul(a, b)
    case default; r = iv_div(a, b)
    end select
  end function arith_value

  !> a**b with both arguments intervals: exp(b log a) for a > 0; an integral constant b
  !> (a degenerate interval) as OP_POWC; otherwise no claim.
  pure function ivd_pow(a, b) result(r)
    type(ivd_t), intent(in) :: a, b
    type(ivd_t) :: r
    real(dp) :: la(2), d1(2)
    if (b%v(1) == b%v(2) .and. all(b%gx == 0.0_dp) .and. all(b%gy == 0.0_dp)) then
      r = ivd_powc(a, b%v(1))
      return
    end if
    if (.not. a%v(1) > 0.0_dp) then
      r = ivd_t(v=entire_iv(), smooth=.false.)
      return
    end if
    la = iv_log(a%v, 1.0_dp)
    r%v = iv_mono(OP_EXP, iv_mul(b%v, la))
    r%smooth = a%smooth .and. b%smooth
    if (.not. r%smooth) return
    r%c = iv_mono(OP_EXP, iv_mul(b%c, iv_log(a%c, 1.0_dp)))
    ! (a^b)' = a^b (b' log a + b a' / a)
    d1 = iv_div(b%v, a%v)
    r%gx = iv_mul(r%v, iv_add(iv_mul(b%gx, la), iv_mul(d1, a%gx)))
    r%gy = iv_mul(r%v, iv_add(iv_mul(b%gy, la), iv_mul(d1, a%gy)))
  end function ivd_pow

  !> min or max of a and b where neither is below the other on the whole box: the value
  !> v, the centroid value c, the gradients' hull (the generalised gradient of a min or max
  !> of Lipschitz functions lies in the convex hull of theirs).
  pure function hull(a, b, v, c) result(r)
    type(ivd_t), intent(in) :: a, b
    real(dp), intent(in) :: v(2), c(2)
    type(ivd_t) :: r
    r%v = v
    r%c = c
    r%gx = [min(a%gx(1), b%gx(1)), max(a%gx(2), b%gx(2))]
    r%gy = [min(a%gy(1), b%gy(1)), max(a%gy(2), b%gy(2))]
    r%smooth = a%smooth .and. b%smooth
  end function hull

  !> atan2(a, b), the angle of the point (b, a): on a box that avoids the origin and the
  !> cut (b < 0, a = 0) its extremes are at the corners; otherwise [-pi, pi], no gradient.
  pure function ivd_atan2(a, b) result(r)
    type(ivd_t), intent(in) :: a, b
    type(ivd_t) :: r
    real(dp) :: n2(2)
    if (b%v(1) > 0.0_dp .or. a%v(1) > 0.0_dp .or. a%v(2) < 0.0_dp) then
      r%v = atan2_value(a%v, b%v)
      r%smooth = a%smooth .and. b%smooth
      if (.not. r%smooth) return
      r%c = atan2_value(a%c, b%c)
      ! d atan2(a, b) = (b da - a db) / (a^2 + b^2)
      n2 = iv_add(iv_sqr(a%v), iv_sqr(b%v))
      r%gx = iv_div(iv_sub(iv_mul(b%v, a%gx), iv_mul(a%v, b%gx)), n2)
      r%gy = iv_div(iv_sub(iv_mul(b%v, a%gy), iv_mul(a%v, b%gy)), n2)
    else
      r = ivd_t(v=widen([-pi, pi]), smooth=.false.)
    end if
  end function ivd_atan2

  !> atan2 on a box that avoids the origin and the cut: the hull of its corner values.
  pure function atan2_value(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2), c(4)
    c = [atan2(a(1), b(1)), atan2(a(1), b(2)), atan2(a(2), b(1)), atan2(a(2), b(2))]
    r = widen([minval(c), maxval(c)])
  end function atan2_value

  !> The result of a comparison or logical operation decided as 0 or 1 (tv = 0, 1), or
  !> undecided (tv = -1: the interval [0, 1], a jump on the triangle).
  pure function logical_result(tv) result(r)
    integer, intent(in) :: tv
    type(ivd_t) :: r
    select case (tv)
    case (0, 1)
      r = ivd_t(v=[real(tv, dp), real(tv, dp)], c=[real(tv, dp), real(tv, dp)])
    case default
      r = ivd_t(v=[0.0_dp, 1.0_dp], smooth=.false.)
    end select
  end function logical_result

  !> 1 when the comparison (or and/or) holds on the whole box, 0 when it fails on all of
  !> it, -1 when undecided.
  pure integer function compare(op, a, b) result(tv)
    integer, intent(in) :: op
    real(dp), intent(in) :: a(2), b(2)
    integer :: ta, tb
    tv = -1
    select case (op)
    case (OP_LT)
      if (a(2) < b(1)) tv = 1
      if (a(1) >= b(2)) tv = 0
    case (OP_LE)
      if (a(2) <= b(1)) tv = 1
      if (a(1) > b(2)) tv = 0
    case (OP_GT)
      if (a(1) > b(2)) tv = 1
      if (a(2) <= b(1)) tv = 0
    case (OP_GE)
      if (a(1) >= b(2)) tv = 1
      if (a(2) < b(1)) tv = 0
    case (OP_EQ, OP_NE)
      if (a(1) == a(2) .and. b(1) == b(2) .and. a(1) == b(1)) tv = 1
      if (a(2) < b(1) .or. b(2) < a(1)) tv = 0
      if (op == OP_NE .and. tv >= 0) tv = 1 - tv
    case (OP_AND, OP_OR)
      ta = truth(a)
      tb = truth(b)
      if (op == OP_AND) then
        if (ta == 1 .and. tb == 1) tv = 1
        if (ta == 0 .or. tb == 0) tv = 0
      else
        if (ta == 1 .or. tb == 1) tv = 1
        if (ta == 0 .and. tb == 0) tv = 0
      end if
    end select
    if (any(ieee_is_nan([a, b]))) tv = -1
  end function compare

  !> 1 when every value of a is true (non-zero), 0 when a = [0, 0], -1 otherwise.
  pure integer function truth(a) result(tv)
    real(dp), intent(in) :: a(2)
    tv = -1
    if (a(1) > 0.0_dp .or. a(2) < 0.0_dp) tv = 1
    if (a(1) == 0.0_dp .and. a(2) == 0.0_dp) tv = 0
  end function truth

  ! ------------------------------------------------------------------ intervals

  !> The interval moved outwards by range_rel_widen of its bounds and the smallest normal
  !> number (a NaN bound gives the whole line).
  pure function widen(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (a(1) /= a(1) .or. a(2) /= a(2)) then          ! NaN
      r = entire_iv()
      return
    end if
    r(1) = a(1) - (range_rel_widen * abs(a(1)) + tiny(1.0_dp))
    r(2) = a(2) + (range_rel_widen * abs(a(2)) + tiny(1.0_dp))
    if (abs(a(1)) > huge(1.0_dp)) r(1) = a(1)            ! an infinite bound stays
    if (abs(a(2)) > huge(1.0_dp)) r(2) = a(2)
  end function widen

  !> Whether a has values of both signs (a sign change, a kink of abs or min, may lie inside).
  pure logical function straddles(a)
    real(dp), intent(in) :: a(2)
    straddles = a(1) < 0.0_dp .and. a(2) > 0.0_dp
  end function straddles

  !> Whether a is the whole line (or has a NaN bound): the value at a point may be NaN.
  pure logical function no_claim(a)
    real(dp), intent(in) :: a(2)
    no_claim = a(1) /= a(1) .or. a(2) /= a(2) .or. (a(1) < -huge(1.0_dp) .and. a(2) > huge(1.0_dp))
  end function no_claim

  !> The whole line, no gradient.
  pure function no_claim_ivd() result(r)
    type(ivd_t) :: r
    r = ivd_t(v=entire_iv(), smooth=.false.)
  end function no_claim_ivd

  pure function entire_iv() result(r)
    real(dp) :: r(2)
    r = [-ieee_value(1.0_dp, ieee_positive_inf), ieee_value(1.0_dp, ieee_positive_inf)]
  end function entire_iv

  pure subroutine entire(lo, hi)
    real(dp), intent(out) :: lo, hi
    lo = -ieee_value(1.0_dp, ieee_positive_inf)
    hi = ieee_value(1.0_dp, ieee_positive_inf)
  end subroutine entire

  pure function iv_add(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2)
    r = widen([a(1) + b(1), a(2) + b(2)])
  end function iv_add

  pure function iv_sub(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2)
    r = widen([a(1) - b(2), a(2) - b(1)])
  end function iv_sub

  !> c a for a number c.
  pure function iv_scale(c, a) result(r)
    real(dp), intent(in) :: c, a(2)
    real(dp) :: r(2)
    r = iv_mul([c, c], a)
  end function iv_scale

  !> The product; the whole line where 0 may meet an infinite bound (0 * Inf is NaN at a
  !> point whose factor overflowed: the invariant of the module header).
  pure function iv_mul(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2), p(4)
    if (a(1) /= a(1) .or. a(2) /= a(2) .or. b(1) /= b(1) .or. b(2) /= b(2)) then
      r = entire_iv()
      return
    end if
    p = [a(1) * b(1), a(1) * b(2), a(2) * b(1), a(2) * b(2)]
    if (any(p /= p)) then                              ! 0 * Inf
      r = entire_iv()
    else
      r = widen([minval(p), maxval(p)])
    end if
  end function iv_mul

  !> The quotient; the whole line when b contains 0.
  pure function iv_div(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2), p(4)
    if (.not. (b(1) > 0.0_dp .or. b(2) < 0.0_dp)) then
      r = entire_iv()
      return
    end if
    p = [a(1) / b(1), a(1) / b(2), a(2) / b(1), a(2) / b(2)]
    if (any(ieee_is_nan(p))) then
      r = entire_iv()
    else
      r = widen([minval(p), maxval(p)])
    end if
  end function iv_div

  pure function iv_sqr(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (a(1) >= 0.0_dp) then
      r = widen([a(1) * a(1), a(2) * a(2)])
    else if (a(2) <= 0.0_dp) then
      r = widen([a(2) * a(2), a(1) * a(1)])
    else
      r = widen([0.0_dp, max(a(1) * a(1), a(2) * a(2))])
      r(1) = 0.0_dp
    end if
  end function iv_sqr

  pure function iv_abs(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (a(1) >= 0.0_dp) then
      r = a
    else if (a(2) <= 0.0_dp) then
      r = [-a(2), -a(1)]
    else
      r = [0.0_dp, max(-a(1), a(2))]
    end if
  end function iv_abs

  !> a**n for an integer n.
  pure recursive function iv_powi(a, n) result(r)
    real(dp), intent(in) :: a(2)
    integer, intent(in) :: n
    real(dp) :: r(2)
    if (n == 0) then
      r = [1.0_dp, 1.0_dp]
    else if (n < 0) then
      r = iv_div([1.0_dp, 1.0_dp], iv_powi(a, -n))
    else if (mod(n, 2) == 1 .or. a(1) >= 0.0_dp) then
      r = widen([a(1)**n, a(2)**n])                  ! increasing there
    else if (a(2) <= 0.0_dp) then
      r = widen([a(2)**n, a(1)**n])                  ! even n, decreasing on a <= 0
    else
      r = widen([0.0_dp, max(a(1)**n, a(2)**n)])     ! even n, minimum 0 at 0
      r(1) = 0.0_dp
    end if
  end function iv_powi

  !> a**c for a real constant c: integral c as iv_powi, otherwise for a >= 0 only.
  pure function iv_powc(a, c) result(r)
    real(dp), intent(in) :: a(2), c
    real(dp) :: r(2)
    if (c == aint(c) .and. abs(c) < 2.0_dp**30) then
      r = iv_powi(a, int(c))
    else if (.not. a(1) >= 0.0_dp) then
      r = entire_iv()
    else if (c > 0.0_dp) then
      r = widen([a(1)**c, a(2)**c])
    else if (a(1) == 0.0_dp) then
      r = widen([a(2)**c, ieee_value(1.0_dp, ieee_positive_inf)])
    else
      r = widen([a(2)**c, a(1)**c])
    end if
  end function iv_powc

  !> An increasing function on the whole line: exp, atan, sinh, tanh.
  pure function iv_mono(op, a) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    select case (op)
    case (OP_EXP); r = widen([exp(a(1)), exp(a(2))]); r(1) = max(r(1), 0.0_dp)
    case (OP_ATAN); r = widen([atan(a(1)), atan(a(2))])
    case (OP_SINH); r = widen([sinh(a(1)), sinh(a(2))])
    case (OP_TANH); r = widen([tanh(a(1)), tanh(a(2))])
    case default; r = entire_iv()
    end select
  end function iv_mono

  !> c log(a) (c > 0: log and log10); the whole line when a reaches below 0.
  pure function iv_log(a, c) result(r)
    real(dp), intent(in) :: a(2), c
    real(dp) :: r(2)
    if (.not. a(1) >= 0.0_dp) then
      r = entire_iv()
    else
      r = widen([c * log(a(1)), c * log(a(2))])
    end if
  end function iv_log

  pure function iv_sqrt(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (.not. a(1) >= 0.0_dp) then
      r = entire_iv()
    else
      r = widen([sqrt(a(1)), sqrt(a(2))])
      r(1) = max(r(1), 0.0_dp)
    end if
  end function iv_sqrt

  !> asin (increasing) or acos (decreasing) on [-1, 1]; the whole line beyond.
  pure function iv_arc(op, a) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (.not. (a(1) >= -1.0_dp .and. a(2) <= 1.0_dp)) then
      r = entire_iv()
    else if (op == OP_ASIN) then
      r = widen([asin(a(1)), asin(a(2))])
    else
      r = widen([acos(a(2)), acos(a(1))])
    end if
  end function iv_arc

  pure function iv_cosh(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2)
    if (a(1) >= 0.0_dp) then
      r = widen([cosh(a(1)), cosh(a(2))])
    else if (a(2) <= 0.0_dp) then
      r = widen([cosh(a(2)), cosh(a(1))])
    else
      r = widen([1.0_dp, max(cosh(a(1)), cosh(a(2)))])
      r(1) = 1.0_dp
    end if
  end function iv_cosh

  !> sin on an interval: the end values, and -1 or 1 where a minimum or maximum of sin
  !> (-pi/2 or pi/2 plus 2 k pi) may lie in it (tested with a margin for rounding).
  pure function iv_sin(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2), margin
    if (.not. all(ieee_is_finite(a))) then         ! sin(Inf) is NaN (the invariant)
      r = entire_iv()
      return
    end if
    if (a(2) - a(1) >= 2.0_dp * pi) then
      r = [-1.0_dp, 1.0_dp]
      return
    end if
    margin = 16.0_dp * epsilon(1.0_dp) * max(1.0_dp, abs(a(1)), abs(a(2)))
    r = widen([min(sin(a(1)), sin(a(2))), max(sin(a(1)), sin(a(2)))])
    if (holds_point(a, 0.5_dp * pi, margin)) r(2) = 1.0_dp
    if (holds_point(a, -0.5_dp * pi, margin)) r(1) = -1.0_dp
    r = [max(r(1), -1.0_dp), min(r(2), 1.0_dp)]
  end function iv_sin

  !> tan on an interval: the whole line where a pole (pi/2 + k pi) may lie in it.
  pure function iv_tan(a) result(r)
    real(dp), intent(in) :: a(2)
    real(dp) :: r(2), margin, k
    if (.not. all(ieee_is_finite(a)) .or. a(2) - a(1) >= pi) then
      r = entire_iv()
      return
    end if
    margin = 16.0_dp * epsilon(1.0_dp) * max(1.0_dp, abs(a(1)), abs(a(2)))
    k = ceiling((a(1) - margin - 0.5_dp * pi) / pi)
    if (0.5_dp * pi + k * pi <= a(2) + margin) then
      r = entire_iv()
    else
      r = widen([tan(a(1)), tan(a(2))])
    end if
  end function iv_tan

  !> Whether p0 + 2 k pi lies in [a(1) - margin, a(2) + margin] for some integer k.
  pure logical function holds_point(a, p0, margin)
    real(dp), intent(in) :: a(2), p0, margin
    real(dp) :: k
    k = ceiling((a(1) - margin - p0) / (2.0_dp * pi))
    holds_point = p0 + 2.0_dp * k * pi <= a(2) + margin
  end function holds_point
end module dualsig_expression_range
