!> Enclosures of a compiled expression (dualsig_expression) over a box: the range of f(x, y)
!> for all (x, y) with x_lo <= x <= x_hi, y_lo <= y <= y_hi, by interval arithmetic on the
!> same bytecode, with the gradient carried along as intervals (interval dual numbers).
!>
!> expression_range(expr, box, lo, hi): lo <= f <= hi at every point of the box where f is
!> defined.  Two enclosures are intersected:
!> - the natural one: every instruction applied to intervals (x -> [x_lo, x_hi], ...);
!> - the centred (mean-value) form f(m) + G_x (x - m_x) + G_y (y - m_y), m the centre of the
!>   box and G the enclosure of the gradient over the box; valid where f is Lipschitz on the
!>   box (every branch of an `if`, every comparison decided on the whole box; abs, min and
!>   max with their generalised gradients), and of second order in the size of the box where
!>   the natural one is only of first order (x*(1-x) near its maximum).
!> Where an operation may leave its domain on the box (log, sqrt, asin, acos of an interval
!> reaching outside it, a division by an interval containing 0, a non-integer power of a
!> negative number) the enclosure is the whole real line (lo = -Inf, hi = +Inf): no claim.
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
!> Used by the load data (dualsig_load_data through field_t%range_on_box) to find features of
!> f that the cubature's points miss (a strip or a spike between them).
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

  !> An interval dual number: the value's enclosure and the gradient's over the box.
  type :: ivd_t
    real(dp) :: v(2) = 0.0_dp
    real(dp) :: gx(2) = 0.0_dp, gy(2) = 0.0_dp
    logical :: smooth = .true.      !! f Lipschitz on the box, gx, gy enclose its gradient
  end type ivd_t

contains

  !> lo <= f(x, y) <= hi on the box [box(1,1), box(2,1)] x [box(1,2), box(2,2)] (the whole
  !> real line when no finite enclosure is found).  enough (optional): an interval that
  !> suffices the caller; the centred form is not tried when the natural enclosure lies in it.
  subroutine expression_range(expr, box, lo, hi, enough)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: box(2, 2)
    real(dp), intent(out) :: lo, hi
    real(dp), intent(in), optional :: enough(2)
    type(ivd_t) :: whole, centre
    real(dp) :: m(2), cf(2)
    type(ieee_status_type) :: saved
    if (expr%n == 0) then
      lo = 0.0_dp
      hi = 0.0_dp
      return
    end if
    call ieee_get_status(saved)
    call ieee_set_halting_mode(ieee_usual, .false.)
    call ieee_set_halting_mode(ieee_underflow, .false.)
    call enclose(whole, centre, m, cf)
    call ieee_set_status(saved)
  contains

    !> The natural enclosure, and the centred one where it is needed and valid.
    subroutine enclose(whole, centre, m, cf)
      type(ivd_t), intent(out) :: whole, centre
      real(dp), intent(out) :: m(2), cf(2)
      ! the natural enclosure alone first (no gradient) when an enclosure within enough suffices
      if (present(enough)) then
        whole = run_segment(expr, 1, expr%n, box, .false.)
        lo = whole%v(1)
        hi = whole%v(2)
        if (lo >= enough(1) .and. hi <= enough(2)) return
      end if
      whole = run_segment(expr, 1, expr%n, box, .true.)
      lo = whole%v(1)
      hi = whole%v(2)
      if (whole%smooth .and. all(ieee_is_finite([whole%gx, whole%gy]))) then
        m = 0.5_dp * (box(1, :) + box(2, :))
        centre = run_segment(expr, 1, expr%n, reshape([m(1), m(1), m(2), m(2)], [2, 2]), .false.)
        cf = iv_add(iv_add(centre%v, iv_mul(whole%gx, iv_sub(box(:, 1), [m(1), m(1)]))), &
                    iv_mul(whole%gy, iv_sub(box(:, 2), [m(2), m(2)])))
        if (all(ieee_is_finite(cf))) then
          lo = max(lo, cf(1))
          hi = min(hi, cf(2))
        end if
      end if
      if (ieee_is_nan(lo) .or. ieee_is_nan(hi) .or. lo > hi) call entire(lo, hi)
    end subroutine enclose
  end subroutine expression_range

  !> The enclosure of the instructions pc0..pc1 (a whole expression or a branch of an if).
  recursive function run_segment(expr, pc0, pc1, box, grad) result(r)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    real(dp), intent(in) :: box(2, 2)
    logical, intent(in) :: grad               !! the gradient wanted (else every value is marked not smooth)
    type(ivd_t) :: r
    type(ivd_t) :: s(max(expr%depth, 1)), a, b
    integer :: pc, t, op, pelse, pend
    t = 0
    pc = pc0
    do while (pc <= pc1)
      op = expr%code(1, pc)
      select case (op)
      case (OP_CONST)
        t = t + 1
        s(t) = ivd_t(v=[expr%consts(expr%code(2, pc)), expr%consts(expr%code(2, pc))])
      case (OP_X)
        t = t + 1
        s(t) = ivd_t(v=box(:, 1), gx=[1.0_dp, 1.0_dp], smooth=grad)
      case (OP_Y)
        t = t + 1
        s(t) = ivd_t(v=box(:, 2), gy=[1.0_dp, 1.0_dp], smooth=grad)
      case (OP_POWC)
        s(t) = ivd_powc(s(t), expr%consts(expr%code(2, pc)))
      case (OP_IF)
        pelse = expr%code(2, pc)
        pend = expr%code(2, pelse)
        select case (truth(s(t)%v))
        case (1)
          s(t) = run_segment(expr, pc + 1, pelse - 1, box, grad)
        case (0)
          s(t) = run_segment(expr, pelse + 1, pend - 1, box, grad)
        case default
          a = run_segment(expr, pc + 1, pelse - 1, box, grad)
          b = run_segment(expr, pelse + 1, pend - 1, box, grad)
          s(t) = ivd_t(v=[min(a%v(1), b%v(1)), max(a%v(2), b%v(2))], smooth=.false.)
        end select
        pc = pend
      case (OP_ELSE, OP_END)
      case default
        if (op >= 40 .and. op < 60) then
          t = t - 1
          s(t) = ivd_binary(op, s(t), s(t + 1))
        else
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

  !> A unary operation: the value's enclosure, and where a is smooth the gradient's by the
  !> chain rule u'(A) dA.
  pure function ivd_unary(op, a) result(r)
    integer, intent(in) :: op
    type(ivd_t), intent(in) :: a
    type(ivd_t) :: r
    real(dp) :: d(2)
    r%smooth = a%smooth
    select case (op)
    case (OP_NEG)
      r%v = [-a%v(2), -a%v(1)]
      r%gx = [-a%gx(2), -a%gx(1)]
      r%gy = [-a%gy(2), -a%gy(1)]
      return
    case (OP_NOT); r = logical_result(1 - truth(a%v)); return
    case (OP_SQR); r%v = iv_sqr(a%v)
    case (OP_SIN); r%v = iv_sin(a%v)
    case (OP_COS); r%v = iv_sin(iv_add(a%v, [0.5_dp * pi, 0.5_dp * pi]))
    case (OP_TAN); r%v = iv_tan(a%v)
    case (OP_ASIN, OP_ACOS); r%v = iv_arc(op, a%v)
    case (OP_ATAN, OP_EXP, OP_SINH, OP_TANH); r%v = iv_mono(op, a%v)
    case (OP_LOG); r%v = iv_log(a%v, 1.0_dp)
    case (OP_LOG10); r%v = iv_log(a%v, 1.0_dp / log(10.0_dp))
    case (OP_SQRT); r%v = iv_sqrt(a%v)
    case (OP_ABS); r%v = iv_abs(a%v)
    case (OP_COSH); r%v = iv_cosh(a%v)
    case default
      r = ivd_t(v=entire_iv(), smooth=.false.)
      return
    end select
    if (.not. r%smooth) return                ! no gradient wanted (or none exists)
    select case (op)
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
    r%smooth = a%smooth
    r%v = iv_powc(a%v, c)
    if (.not. r%smooth) return
    d = iv_scale(c, iv_powc(a%v, c - 1.0_dp))
    if (c == 0.0_dp) d = [0.0_dp, 0.0_dp]
    r%gx = iv_mul(d, a%gx)
    r%gy = iv_mul(d, a%gy)
  end function ivd_powc

  !> A binary operation a op b.
  pure function ivd_binary(op, a, b) result(r)
    integer, intent(in) :: op
    type(ivd_t), intent(in) :: a, b
    type(ivd_t) :: r
    r%smooth = a%smooth .and. b%smooth
    select case (op)
    case (OP_ADD)
      r%v = iv_add(a%v, b%v)
      if (r%smooth) r%gx = iv_add(a%gx, b%gx)
      if (r%smooth) r%gy = iv_add(a%gy, b%gy)
    case (OP_SUB)
      r%v = iv_sub(a%v, b%v)
      if (r%smooth) r%gx = iv_sub(a%gx, b%gx)
      if (r%smooth) r%gy = iv_sub(a%gy, b%gy)
    case (OP_MUL)
      r%v = iv_mul(a%v, b%v)
      if (r%smooth) r%gx = iv_add(iv_mul(a%gx, b%v), iv_mul(a%v, b%gx))
      if (r%smooth) r%gy = iv_add(iv_mul(a%gy, b%v), iv_mul(a%v, b%gy))
    case (OP_DIV)
      r%v = iv_div(a%v, b%v)
      ! (a/b)' = (a' - (a/b) b') / b
      if (r%smooth) r%gx = iv_div(iv_sub(a%gx, iv_mul(r%v, b%gx)), b%v)
      if (r%smooth) r%gy = iv_div(iv_sub(a%gy, iv_mul(r%v, b%gy)), b%v)
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
        r = hull(a, b, [min(a%v(1), b%v(1)), min(a%v(2), b%v(2))])
      end if
    case (OP_MAX)
      if (a%v(1) >= b%v(2)) then
        r = a
      else if (b%v(1) > a%v(2)) then
        r = b
      else
        r = hull(a, b, [max(a%v(1), b%v(1)), max(a%v(2), b%v(2))])
      end if
    case default
      ! comparisons, and, or: 0 or 1, a jump where undecided
      r = logical_result(compare(op, a%v, b%v))
    end select
  end function ivd_binary

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
    ! (a^b)' = a^b (b' log a + b a' / a)
    d1 = iv_div(b%v, a%v)
    r%gx = iv_mul(r%v, iv_add(iv_mul(b%gx, la), iv_mul(d1, a%gx)))
    r%gy = iv_mul(r%v, iv_add(iv_mul(b%gy, la), iv_mul(d1, a%gy)))
  end function ivd_pow

  !> min or max of a and b where neither is below the other on the whole box: the value
  !> v, the gradients' hull (the generalised gradient of a min or max of Lipschitz functions
  !> lies in the convex hull of theirs).
  pure function hull(a, b, v) result(r)
    type(ivd_t), intent(in) :: a, b
    real(dp), intent(in) :: v(2)
    type(ivd_t) :: r
    r%v = v
    r%gx = [min(a%gx(1), b%gx(1)), max(a%gx(2), b%gx(2))]
    r%gy = [min(a%gy(1), b%gy(1)), max(a%gy(2), b%gy(2))]
    r%smooth = a%smooth .and. b%smooth
  end function hull

  !> atan2(a, b), the angle of the point (b, a): on a box that avoids the origin and the
  !> cut (b < 0, a = 0) its extremes are at the corners; otherwise [-pi, pi], no gradient.
  pure function ivd_atan2(a, b) result(r)
    type(ivd_t), intent(in) :: a, b
    type(ivd_t) :: r
    real(dp) :: c(4), n2(2)
    if (b%v(1) > 0.0_dp .or. a%v(1) > 0.0_dp .or. a%v(2) < 0.0_dp) then
      c = [atan2(a%v(1), b%v(1)), atan2(a%v(1), b%v(2)), atan2(a%v(2), b%v(1)), atan2(a%v(2), b%v(2))]
      r%v = widen([minval(c), maxval(c)])
      r%smooth = a%smooth .and. b%smooth
      if (.not. r%smooth) return
      ! d atan2(a, b) = (b da - a db) / (a^2 + b^2)
      n2 = iv_add(iv_sqr(a%v), iv_sqr(b%v))
      r%gx = iv_div(iv_sub(iv_mul(b%v, a%gx), iv_mul(a%v, b%gx)), n2)
      r%gy = iv_div(iv_sub(iv_mul(b%v, a%gy), iv_mul(a%v, b%gy)), n2)
    else
      r = ivd_t(v=widen([-pi, pi]), smooth=.false.)
    end if
  end function ivd_atan2

  !> The result of a comparison or logical operation decided as 0 or 1 (tv = 0, 1), or
  !> undecided (tv = -1: the interval [0, 1], a jump on the box).
  pure function logical_result(tv) result(r)
    integer, intent(in) :: tv
    type(ivd_t) :: r
    select case (tv)
    case (0, 1)
      r = ivd_t(v=[real(tv, dp), real(tv, dp)])
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

  !> The product; 0 times an infinite bound counts as 0.
  pure function iv_mul(a, b) result(r)
    real(dp), intent(in) :: a(2), b(2)
    real(dp) :: r(2), p(4)
    integer :: k
    if (a(1) /= a(1) .or. a(2) /= a(2) .or. b(1) /= b(1) .or. b(2) /= b(2)) then
      r = entire_iv()
      return
    end if
    p = [a(1) * b(1), a(1) * b(2), a(2) * b(1), a(2) * b(2)]
    do k = 1, 4
      if (p(k) /= p(k)) p(k) = 0.0_dp                   ! 0 * Inf
    end do
    r = widen([minval(p), maxval(p)])
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
    if (.not. all(ieee_is_finite(a)) .or. a(2) - a(1) >= 2.0_dp * pi) then
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
