!> The expression language of users' own problems: f, g, u written as text in a namelist.
!>
!> An expression of x and y (numbers, x, y, pi, + - * / ** ^, parentheses, the functions
!> sin cos tan asin acos atan atan2 exp log log10 sqrt abs min max sinh cosh tanh, the
!> comparisons < <= > >= == /=, and, or, not, and the conditional if(cond, a, b)) is compiled
!> once by `expression_compile` into a bytecode for a stack machine: a list of instructions
!> (opcode, argument) and a table of constants, the stack depth known at compile time, the
!> sub-expressions without x and y folded into constants.  The grammar, the precedence table
!> and the messages are in doc/expressions.md.
!>
!> Evaluation:
!> - `expression_eval(expr, x, y, v)` over arrays of points, the fast path: each instruction
!>   is applied to a block of points at once (blocks of `block_size`); the two branches of an
!>   `if` are evaluated only on the points that select them (packed into a smaller block), so
!>   `if(x > 0, log(x), 0)` never evaluates log at x <= 0;
!> - `expression_value(expr, x, y)` at one point (the same operations, the same bits);
!> - `expression_eval_grad` / `expression_value_grad`: value and gradient (d/dx, d/dy) by
!>   forward-mode automatic differentiation (dual numbers) of the same bytecode.  abs, min,
!>   max and if differentiate their active branch (abs'(0) = 1, min/max take the first
!>   argument on a tie); comparisons, and, or, not have derivative 0.  At a point where the
!>   function is not differentiable (sqrt(0), log(0), asin(+-1), 0**c with c < 1, ...) the
!>   derivative is Inf or NaN.
!>
!> Arithmetic is IEEE: 1/0 gives Inf, log(-1) NaN.  Detecting a non-finite value is the
!> caller's task: `expression_check_finite` evaluates (with floating-point traps disarmed)
!> and returns the first point where the value (or the gradient) is not finite.  Without it,
!> a build that traps floating-point exceptions (make BUILD=debug) stops there.
module dualsig_expression
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: ieee_exceptions, only: ieee_status_type, ieee_get_status, ieee_set_status, &
                                           ieee_usual, ieee_set_halting_mode
  use dualsig_kinds, only: dp, pi
  use dualsig_status, only: status_t, set_error, is_error, DS_ERR_INPUT
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: expression_t
  public :: expression_compile, expression_compile_input, expression_input_message
  public :: expression_eval, expression_value, expression_eval_grad, expression_value_grad
  public :: expression_check_finite
  ! the bytecode, for evaluators in other modules (dualsig_expression_range)
  public :: OP_CONST, OP_X, OP_Y, OP_NEG, OP_SQR, OP_POWC, OP_NOT, OP_SIN, OP_COS, OP_TAN, OP_ASIN, &
            OP_ACOS, OP_ATAN, OP_EXP, OP_LOG, OP_LOG10, OP_SQRT, OP_ABS, OP_SINH, OP_COSH, OP_TANH, &
            OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW, OP_ATAN2, OP_MIN, OP_MAX, OP_LT, OP_LE, OP_GT, OP_GE, &
            OP_EQ, OP_NE, OP_AND, OP_OR, OP_IF, OP_ELSE, OP_END

  !> A compiled expression.  `code(1, k)` is the opcode of instruction k, `code(2, k)` its
  !> argument (a constant's index, a jump target), `consts` the constants, `depth` the
  !> largest stack depth.  Empty (n = 0) until compiled.
  type :: expression_t
    integer :: n = 0                                  !! number of instructions
    integer, allocatable :: code(:, :)                !! (2, n): opcode, argument
    real(dp), allocatable :: consts(:)                !! constants of OP_CONST and OP_POWC
    integer :: depth = 0                              !! stack depth needed by the evaluation
    character(len=:), allocatable :: source           !! the text compiled
  end type expression_t

  !> Points evaluated together by the array evaluation (keeps the stack in cache).
  integer, parameter :: block_size = 256
  !> Deepest nesting of parentheses, calls, signs and powers the compiler accepts.
  integer, parameter :: max_nesting = 400

  ! opcodes: leaves
  integer, parameter :: OP_CONST = 1, OP_X = 2, OP_Y = 3
  ! unary operators and functions (20..39)
  integer, parameter :: OP_NEG = 20, OP_SQR = 21, OP_POWC = 22, OP_NOT = 23, OP_SIN = 24, OP_COS = 25, &
                        OP_TAN = 26, OP_ASIN = 27, OP_ACOS = 28, OP_ATAN = 29, OP_EXP = 30, OP_LOG = 31, &
                        OP_LOG10 = 32, OP_SQRT = 33, OP_ABS = 34, OP_SINH = 35, OP_COSH = 36, OP_TANH = 37
  ! binary operators and functions (40..59)
  integer, parameter :: OP_ADD = 40, OP_SUB = 41, OP_MUL = 42, OP_DIV = 43, OP_POW = 44, OP_ATAN2 = 45, &
                        OP_MIN = 46, OP_MAX = 47, OP_LT = 48, OP_LE = 49, OP_GT = 50, OP_GE = 51, &
                        OP_EQ = 52, OP_NE = 53, OP_AND = 54, OP_OR = 55
  ! the conditional: IF (argument: its ELSE), ELSE (argument: its END), END
  integer, parameter :: OP_IF = 60, OP_ELSE = 61, OP_END = 62

  ! tokens
  integer, parameter :: T_END = 0, T_NUM = 1, T_NAME = 2, T_PLUS = 3, T_MINUS = 4, T_STAR = 5, &
                        T_SLASH = 6, T_POW = 7, T_LP = 8, T_RP = 9, T_COMMA = 10, T_LT = 11, T_LE = 12, &
                        T_GT = 13, T_GE = 14, T_EQ = 15, T_NE = 16

  ! the functions: name, opcode, fewest and most arguments (-1: any number)
  integer, parameter :: nfun = 18
  character(len=5), parameter :: fun_name(nfun) = [character(len=5) :: 'sin', 'cos', 'tan', 'asin', &
    'acos', 'atan', 'atan2', 'exp', 'log', 'log10', 'sqrt', 'abs', 'min', 'max', 'sinh', 'cosh', 'tanh', 'if']
  integer, parameter :: fun_op(nfun) = [OP_SIN, OP_COS, OP_TAN, OP_ASIN, OP_ACOS, OP_ATAN, OP_ATAN2, &
    OP_EXP, OP_LOG, OP_LOG10, OP_SQRT, OP_ABS, OP_MIN, OP_MAX, OP_SINH, OP_COSH, OP_TANH, OP_IF]
  integer, parameter :: fun_min(nfun) = [1, 1, 1, 1, 1, 1, 2, 1, 1, 1, 1, 1, 2, 2, 1, 1, 1, 3]
  integer, parameter :: fun_max(nfun) = [1, 1, 1, 1, 1, 1, 2, 1, 1, 1, 1, 1, -1, -1, 1, 1, 1, 3]

  !> The compiler's state: the text, the current token, the code being emitted, the error.
  type :: parser_t
    character(len=:), allocatable :: s            !! the text
    integer :: pos = 1                            !! where the lexer goes on
    integer :: tok = T_END                        !! current token
    integer :: col = 1                            !! its column
    integer :: tend = 0                           !! its last character
    real(dp) :: num = 0.0_dp                      !! its value (T_NUM)
    character(len=:), allocatable :: name         !! its lower-case text (T_NAME)
    integer :: nest = 0                           !! current nesting
    integer :: n = 0, nconst = 0, depth = 0, max_depth = 0
    integer, allocatable :: code(:, :)
    real(dp), allocatable :: consts(:)
    logical :: failed = .false.
    character(len=:), allocatable :: msg
  end type parser_t

contains

  ! ------------------------------------------------------------------ compiling

  !> Compile `text`.  On error `st` is DS_ERR_INPUT with a message `column N: ...` (column of
  !> `text`, from 1) and `expr` is left empty.  Floating-point traps are disarmed while the
  !> constants are read and folded (a constant like 1/0 becomes Inf, for
  !> expression_check_finite to report).
  subroutine expression_compile(text, expr, st)
    character(len=*), intent(in) :: text
    type(expression_t), intent(out) :: expr
    type(status_t), intent(out) :: st
    type(parser_t) :: p
    type(ieee_status_type) :: saved

    call ieee_get_status(saved)
    call ieee_set_halting_mode(ieee_usual, .false.)
    p%s = text
    allocate (p%code(2, 16), p%consts(8))                 ! small: fixed size
    if (len_trim(text) == 0 .or. verify(text, ' ' // achar(9) // achar(10) // achar(13)) == 0) then
      call fail(p, 1, 'empty expression')
    else
      call next_token(p)
      if (.not. p%failed) call parse_or(p)
      if (.not. p%failed .and. p%tok /= T_END) then
        if (p%tok == T_RP) then
          call fail(p, p%col, "unbalanced ')'")
        else
          call fail(p, p%col, 'expected an operator or the end of the expression, found ' // found(p))
        end if
      end if
    end if
    call ieee_set_status(saved)
    if (p%failed) then
      call set_error(st, DS_ERR_INPUT, p%msg)
      return
    end if
    expr%n = p%n
    expr%code = p%code(:, 1:p%n)
    expr%consts = p%consts(1:max(p%nconst, 1))
    expr%depth = max(p%max_depth, 1)
    expr%source = text
  end subroutine expression_compile

  !> Compile `text`, the value of `variable` of namelist group `group` in `file`; an error
  !> message names them: `data/x.nml: &problem f = '3*x +* y': column 6: expected an operand`.
  subroutine expression_compile_input(text, file, group, variable, expr, st)
    character(len=*), intent(in) :: text, file, group, variable
    type(expression_t), intent(out) :: expr
    type(status_t), intent(out) :: st
    call expression_compile(text, expr, st)
    if (is_error(st)) st%msg = expression_input_message(file, group, variable, text, st%msg)
  end subroutine expression_compile_input

  !> The full message of a compile error: `file: &group variable = 'text': msg`.  A text
  !> longer than 72 characters is quoted by its first 69 and '...' (the column still counts
  !> in the whole text).
  pure function expression_input_message(file, group, variable, text, msg) result(full)
    character(len=*), intent(in) :: file, group, variable, text, msg
    character(len=:), allocatable :: full
    character(len=:), allocatable :: shown
    if (len_trim(text) > 72) then
      shown = text(1:69) // '...'
    else
      shown = trim(text)
    end if
    full = file // ': &' // group // ' ' // variable // " = '" // shown // "': " // msg
  end function expression_input_message

  !> Record the first error, at column col.
  subroutine fail(p, col, msg)
    type(parser_t), intent(inout) :: p
    integer, intent(in) :: col
    character(len=*), intent(in) :: msg
    if (p%failed) return
    p%failed = .true.
    p%msg = 'column ' // itoa(col) // ': ' // msg
  end subroutine fail

  !> The current token for a message: 'text' or "the end of the expression".
  function found(p) result(s)
    type(parser_t), intent(in) :: p
    character(len=:), allocatable :: s
    if (p%tok == T_END) then
      s = 'the end of the expression'
    else
      s = "'" // p%s(p%col:p%tend) // "'"
    end if
  end function found

  pure logical function is_blank(c)
    character, intent(in) :: c
    is_blank = c == ' ' .or. c == achar(9) .or. c == achar(10) .or. c == achar(13)
  end function is_blank

  pure logical function is_digit(c)
    character, intent(in) :: c
    is_digit = c >= '0' .and. c <= '9'
  end function is_digit

  pure logical function is_letter(c)
    character, intent(in) :: c
    is_letter = (c >= 'a' .and. c <= 'z') .or. (c >= 'A' .and. c <= 'Z')
  end function is_letter

  pure function to_lower(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: i
    t = s
    do i = 1, len(s)
      if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') t(i:i) = achar(iachar(s(i:i)) + 32)
    end do
  end function to_lower

  !> Read the next token (blanks between tokens are skipped).
  subroutine next_token(p)
    type(parser_t), intent(inout) :: p
    integer :: n, i
    character :: c, d
    n = len(p%s)
    do while (p%pos <= n)
      if (.not. is_blank(p%s(p%pos:p%pos))) exit
      p%pos = p%pos + 1
    end do
    p%col = p%pos
    p%tend = p%pos
    if (p%pos > n) then
      p%tok = T_END
      return
    end if
    c = p%s(p%pos:p%pos)
    d = ' '
    if (p%pos < n) d = p%s(p%pos + 1:p%pos + 1)
    if (is_digit(c) .or. (c == '.' .and. is_digit(d))) then
      call lex_number(p)
      return
    end if
    if (is_letter(c)) then
      i = p%pos
      do while (i < n)
        if (.not. (is_letter(p%s(i + 1:i + 1)) .or. is_digit(p%s(i + 1:i + 1)) .or. p%s(i + 1:i + 1) == '_')) exit
        i = i + 1
      end do
      p%tok = T_NAME
      p%name = to_lower(p%s(p%pos:i))
      p%tend = i
      p%pos = i + 1
      return
    end if
    p%tend = p%pos
    select case (c)
    case ('+'); p%tok = T_PLUS
    case ('-'); p%tok = T_MINUS
    case ('^'); p%tok = T_POW
    case ('('); p%tok = T_LP
    case (')'); p%tok = T_RP
    case (','); p%tok = T_COMMA
    case ('*')
      p%tok = T_STAR
      if (d == '*') p%tok = T_POW
    case ('/')
      p%tok = T_SLASH
      if (d == '=') p%tok = T_NE
    case ('<')
      p%tok = T_LT
      if (d == '=') p%tok = T_LE
    case ('>')
      p%tok = T_GT
      if (d == '=') p%tok = T_GE
    case ('=')
      if (d /= '=') then
        call fail(p, p%col, "unexpected '=' (the comparison is '==')")
        return
      end if
      p%tok = T_EQ
    case default
      call fail(p, p%col, "unexpected character '" // c // "'")
      return
    end select
    if (any(p%tok == [T_POW, T_NE, T_LE, T_GE, T_EQ]) .and. c /= '^') p%tend = p%pos + 1
    p%pos = p%tend + 1
  end subroutine next_token

  !> A number: digits [. digits] [(e|d) [sign] digits], or . digits [...].
  subroutine lex_number(p)
    type(parser_t), intent(inout) :: p
    integer :: n, i, ios
    character(len=:), allocatable :: t
    n = len(p%s)
    i = p%pos
    do while (i <= n)
      if (.not. is_digit(p%s(i:i))) exit
      i = i + 1
    end do
    if (i <= n) then
      if (p%s(i:i) == '.') then
        i = i + 1
        do while (i <= n)
          if (.not. is_digit(p%s(i:i))) exit
          i = i + 1
        end do
      end if
    end if
    if (i <= n) then
      if (index('eEdD', p%s(i:i)) > 0) then
        i = i + 1
        if (i <= n) then
          if (p%s(i:i) == '+' .or. p%s(i:i) == '-') i = i + 1
        end if
        if (i > n) then
          call fail(p, p%col, "malformed number '" // p%s(p%col:n) // "': digits expected in the exponent")
          return
        else if (.not. is_digit(p%s(i:i))) then
          call fail(p, p%col, "malformed number '" // p%s(p%col:i) // "': digits expected in the exponent")
          return
        end if
        do while (i <= n)
          if (.not. is_digit(p%s(i:i))) exit
          i = i + 1
        end do
      end if
    end if
    t = to_lower(p%s(p%pos:i - 1))
    if (index(t, 'd') > 0) t(index(t, 'd'):index(t, 'd')) = 'e'
    read (t, *, iostat=ios) p%num
    if (ios /= 0) then
      call fail(p, p%col, "malformed number '" // p%s(p%pos:i - 1) // "'")
      return
    end if
    if (.not. ieee_is_finite(p%num)) then
      call fail(p, p%col, "number out of range '" // p%s(p%pos:i - 1) // "'")
      return
    end if
    p%tok = T_NUM
    p%tend = i - 1
    p%pos = i
  end subroutine lex_number

  !> True when the current token is the word w (and, or, not).
  logical function is_word(p, w)
    type(parser_t), intent(in) :: p
    character(len=*), intent(in) :: w
    is_word = .false.
    if (p%tok == T_NAME) is_word = p%name == w
  end function is_word

  !> Enter one level of nesting; false (and an error) beyond max_nesting levels below the
  !> expression itself (its own parse_or is level 0: 400 nested parentheses are allowed).
  logical function enter(p)
    type(parser_t), intent(inout) :: p
    p%nest = p%nest + 1
    enter = p%nest <= max_nesting + 1
    if (.not. enter) call fail(p, p%col, 'expression nested too deeply (more than ' // itoa(max_nesting) // ' levels)')
  end function enter

  !> or_expr := and_expr { 'or' and_expr }
  recursive subroutine parse_or(p)
    type(parser_t), intent(inout) :: p
    if (.not. enter(p)) return
    call parse_and(p)
    do while (.not. p%failed .and. is_word(p, 'or'))
      call next_token(p)
      if (p%failed) return
      call parse_and(p)
      call emit(p, OP_OR, 0)
    end do
    p%nest = p%nest - 1
  end subroutine parse_or

  !> and_expr := not_expr { 'and' not_expr }
  recursive subroutine parse_and(p)
    type(parser_t), intent(inout) :: p
    call parse_not(p)
    do while (.not. p%failed .and. is_word(p, 'and'))
      call next_token(p)
      if (p%failed) return
      call parse_not(p)
      call emit(p, OP_AND, 0)
    end do
  end subroutine parse_and

  !> not_expr := 'not' not_expr | comparison
  recursive subroutine parse_not(p)
    type(parser_t), intent(inout) :: p
    if (is_word(p, 'not')) then
      if (.not. enter(p)) return
      call next_token(p)
      if (p%failed) return
      call parse_not(p)
      call emit(p, OP_NOT, 0)
      p%nest = p%nest - 1
    else
      call parse_comparison(p)
    end if
  end subroutine parse_not

  !> comparison := additive [ relop additive ]   (comparisons do not chain)
  recursive subroutine parse_comparison(p)
    type(parser_t), intent(inout) :: p
    integer, parameter :: rel_tok(6) = [T_LT, T_LE, T_GT, T_GE, T_EQ, T_NE]
    integer, parameter :: rel_op(6) = [OP_LT, OP_LE, OP_GT, OP_GE, OP_EQ, OP_NE]
    integer :: k
    call parse_additive(p)
    if (p%failed) return
    k = findloc(rel_tok, p%tok, dim=1)
    if (k == 0) return
    call next_token(p)
    if (p%failed) return
    call parse_additive(p)
    call emit(p, rel_op(k), 0)
    if (p%failed) return
    if (any(rel_tok == p%tok)) call fail(p, p%col, "comparisons do not chain: write (a < b) and (b < c)")
  end subroutine parse_comparison

  !> additive := unary { ('+' | '-') unary }
  recursive subroutine parse_additive(p)
    type(parser_t), intent(inout) :: p
    integer :: op
    call parse_term(p)
    do while (.not. p%failed .and. (p%tok == T_PLUS .or. p%tok == T_MINUS))
      op = merge(OP_ADD, OP_SUB, p%tok == T_PLUS)
      call next_token(p)
      if (p%failed) return
      call parse_term(p)
      call emit(p, op, 0)
    end do
  end subroutine parse_additive

  !> term := unary { ('*' | '/') unary }
  recursive subroutine parse_term(p)
    type(parser_t), intent(inout) :: p
    integer :: op
    call parse_unary(p)
    do while (.not. p%failed .and. (p%tok == T_STAR .or. p%tok == T_SLASH))
      op = merge(OP_MUL, OP_DIV, p%tok == T_STAR)
      call next_token(p)
      if (p%failed) return
      call parse_unary(p)
      call emit(p, op, 0)
    end do
  end subroutine parse_term

  !> unary := ('+' | '-') unary | power.  A sign binds less tightly than ** (-2**2 = -4) and
  !> may follow any operator (2**-1, x*-y).
  recursive subroutine parse_unary(p)
    type(parser_t), intent(inout) :: p
    logical :: minus
    if (p%tok == T_PLUS .or. p%tok == T_MINUS) then
      if (.not. enter(p)) return
      minus = p%tok == T_MINUS
      call next_token(p)
      if (p%failed) return
      call parse_unary(p)
      if (minus) call emit(p, OP_NEG, 0)
      p%nest = p%nest - 1
    else
      call parse_power(p)
    end if
  end subroutine parse_unary

  !> power := primary [ ('**' | '^') unary ]   (right-associative: 2**3**2 = 2**9)
  recursive subroutine parse_power(p)
    type(parser_t), intent(inout) :: p
    call parse_primary(p)
    if (p%failed .or. p%tok /= T_POW) return
    if (.not. enter(p)) return
    call next_token(p)
    if (p%failed) return
    call parse_unary(p)
    call emit(p, OP_POW, 0)
    p%nest = p%nest - 1
  end subroutine parse_power

  !> primary := number | x | y | pi | function '(' args ')' | '(' expr ')'
  recursive subroutine parse_primary(p)
    type(parser_t), intent(inout) :: p
    integer :: col
    select case (p%tok)
    case (T_NUM)
      call emit_const(p, p%num)
      call next_token(p)
    case (T_LP)
      col = p%col
      call next_token(p)
      if (p%failed) return
      call parse_or(p)
      if (p%failed) return
      if (p%tok /= T_RP) then
        call fail(p, p%col, "expected ')' to close the '(' of column " // itoa(col) // ', found ' // found(p))
        return
      end if
      call next_token(p)
    case (T_NAME)
      call parse_name(p)
    case (T_END)
      call fail(p, p%col, 'expected an operand, found the end of the expression')
    case default
      call fail(p, p%col, 'expected an operand')
    end select
  end subroutine parse_primary

  !> A name: x, y, pi or a function call.
  recursive subroutine parse_name(p)
    type(parser_t), intent(inout) :: p
    integer :: col, k
    character(len=:), allocatable :: name
    col = p%col
    name = p%name
    k = 0
    do while (k < nfun)
      k = k + 1
      if (fun_name(k) == name) exit
    end do
    if (fun_name(k) /= name) k = 0
    call next_token(p)
    if (p%failed) return
    select case (name)
    case ('x')
      call emit(p, OP_X, 0)
    case ('y')
      call emit(p, OP_Y, 0)
    case ('pi')
      call emit_const(p, pi)
    case ('and', 'or', 'not')
      call fail(p, col, "expected an operand, found '" // name // "'")
    case default
      if (k == 0) then
        if (p%tok == T_LP) then
          call fail(p, col, "unknown function '" // name // "'")
        else
          call fail(p, col, "unknown name '" // name // "' (the variables are x and y, the constant pi)")
        end if
      else if (p%tok /= T_LP) then
        call fail(p, p%col, "expected '(' after the function " // trim(fun_name(k)))
      else if (fun_op(k) == OP_IF) then
        call parse_if(p, col)
      else
        call parse_call(p, k, col)
      end if
    end select
  end subroutine parse_name

  !> The arguments of function k (the current token is its '('), then the call.
  recursive subroutine parse_call(p, k, col)
    type(parser_t), intent(inout) :: p
    integer, intent(in) :: k, col
    integer :: nargs, lp
    lp = p%col
    nargs = 0
    if (.not. enter(p)) return
    do
      call next_token(p)
      if (p%failed) return
      call parse_or(p)
      if (p%failed) return
      nargs = nargs + 1
      if (nargs > 2 .and. (fun_op(k) == OP_MIN .or. fun_op(k) == OP_MAX)) call emit(p, fun_op(k), 0)
      if (p%tok == T_RP) exit
      if (p%tok /= T_COMMA) then
        call fail(p, p%col, "expected ',' or ')' in the arguments of " // trim(fun_name(k)) // &
                  ' (opened at column ' // itoa(lp) // '), found ' // found(p))
        return
      end if
      if (nargs == 2 .and. (fun_op(k) == OP_MIN .or. fun_op(k) == OP_MAX)) call emit(p, fun_op(k), 0)
    end do
    if (nargs < fun_min(k) .or. (fun_max(k) >= 0 .and. nargs > fun_max(k))) then
      call fail(p, col, trim(fun_name(k)) // ' takes ' // arity(k) // ', found ' // itoa(nargs))
      return
    end if
    if (fun_op(k) /= OP_MIN .and. fun_op(k) /= OP_MAX) then
      call emit(p, fun_op(k), 0)
    else if (nargs == 2) then
      call emit(p, fun_op(k), 0)
    end if
    call next_token(p)
    p%nest = p%nest - 1
  end subroutine parse_call

  !> "1 argument", "2 arguments", "2 or more arguments" for function k.
  function arity(k) result(s)
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    if (fun_max(k) < 0) then
      s = itoa(fun_min(k)) // ' or more arguments'
    else if (fun_min(k) == 1) then
      s = '1 argument'
    else
      s = itoa(fun_min(k)) // ' arguments'
    end if
  end function arity

  !> if(cond, a, b): the current token is its '('.  Code: cond IF a ELSE b END.
  recursive subroutine parse_if(p, col)
    type(parser_t), intent(inout) :: p
    integer, intent(in) :: col
    integer :: lp, j, at_if, at_else
    at_if = 0
    at_else = 0
    lp = p%col
    if (.not. enter(p)) return
    do j = 1, 3
      call next_token(p)
      if (p%failed) return
      call parse_or(p)
      if (p%failed) return
      if (j < 3 .and. p%tok == T_RP) then
        call fail(p, col, 'if takes 3 arguments (condition, value if true, value if false), found ' // itoa(j))
        return
      end if
      if (j == 3 .and. p%tok == T_COMMA) then
        call fail(p, col, 'if takes 3 arguments (condition, value if true, value if false), found more')
        return
      end if
      if (p%tok /= merge(T_RP, T_COMMA, j == 3)) then
        call fail(p, p%col, "expected ',' or ')' in the arguments of if (opened at column " // itoa(lp) // &
                  '), found ' // found(p))
        return
      end if
      if (j == 1) then
        call emit(p, OP_IF, 0)
        at_if = p%n
      else if (j == 2) then
        call emit(p, OP_ELSE, 0)
        at_else = p%n
        p%code(2, at_if) = at_else
      else
        call emit(p, OP_END, 0)
        p%code(2, at_else) = p%n
      end if
    end do
    call next_token(p)
    p%nest = p%nest - 1
  end subroutine parse_if

  !> Append a constant.
  subroutine emit_const(p, c)
    type(parser_t), intent(inout) :: p
    real(dp), intent(in) :: c
    real(dp), allocatable :: tmp(:)
    if (p%nconst == size(p%consts)) then
      allocate (tmp(2 * size(p%consts)))    ! small: at most the length of the text (<= max_line_len)
      tmp(1:p%nconst) = p%consts(1:p%nconst)
      call move_alloc(tmp, p%consts)
    end if
    p%nconst = p%nconst + 1
    p%consts(p%nconst) = c
    call emit(p, OP_CONST, p%nconst)
  end subroutine emit_const

  !> Append an instruction, folding an operation on constants into a constant, and a power
  !> with a constant exponent into OP_SQR or OP_POWC.  In postfix code the last instruction
  !> of an operand is its root, so "the operand is a constant" is "its last instruction is
  !> OP_CONST".
  subroutine emit(p, op, arg)
    type(parser_t), intent(inout) :: p
    integer, intent(in) :: op, arg
    integer, allocatable :: tmp(:, :)
    integer :: ka, kb
    if (p%failed) return
    if (is_unary(op) .and. p%n >= 1) then
      if (p%code(1, p%n) == OP_CONST) then
        ka = p%code(2, p%n)
        p%consts(ka) = apply1(op, p%consts(ka), 0.0_dp)
        return
      end if
    end if
    if (is_binary(op) .and. p%n >= 2) then
      if (p%code(1, p%n) == OP_CONST .and. p%code(1, p%n - 1) == OP_CONST) then
        ka = p%code(2, p%n - 1)
        kb = p%code(2, p%n)
        p%consts(ka) = apply2(op, p%consts(ka), p%consts(kb))
        p%n = p%n - 1
        p%depth = p%depth - 1
        return
      end if
    end if
    if (op == OP_POW .and. p%n >= 1) then
      if (p%code(1, p%n) == OP_CONST) then
        kb = p%code(2, p%n)
        p%depth = p%depth - 1
        if (p%consts(kb) == 2.0_dp) then
          p%code(:, p%n) = [OP_SQR, 0]
        else
          p%code(:, p%n) = [OP_POWC, kb]
        end if
        return
      end if
    end if
    if (p%n == size(p%code, 2)) then
      allocate (tmp(2, 2 * size(p%code, 2)))    ! small: at most the length of the text (<= max_line_len)
      tmp(:, 1:p%n) = p%code(:, 1:p%n)
      call move_alloc(tmp, p%code)
    end if
    p%n = p%n + 1
    p%code(:, p%n) = [op, arg]
    select case (op)
    case (OP_CONST, OP_X, OP_Y)
      p%depth = p%depth + 1
      p%max_depth = max(p%max_depth, p%depth)
    case (OP_IF, OP_ELSE)
      p%depth = p%depth - 1
    case default
      if (is_binary(op)) p%depth = p%depth - 1
    end select
  end subroutine emit

  pure logical function is_unary(op)
    integer, intent(in) :: op
    is_unary = op >= 20 .and. op < 40 .and. op /= OP_POWC
  end function is_unary

  pure logical function is_binary(op)
    integer, intent(in) :: op
    is_binary = op >= 40 .and. op < 60
  end function is_binary

  ! ------------------------------------------------------------------ the operations

  !> A unary operation (c: the exponent of OP_POWC).  Shared by every evaluation path and by
  !> the constant folding, so that all give the same bits.
  elemental real(dp) function apply1(op, a, c) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a, c
    select case (op)
    case (OP_NEG); r = -a
    case (OP_SQR); r = a * a
    case (OP_POWC); r = a**c
    case (OP_NOT); r = merge(1.0_dp, 0.0_dp, a == 0.0_dp)
    case (OP_SIN); r = sin(a)
    case (OP_COS); r = cos(a)
    case (OP_TAN); r = tan(a)
    case (OP_ASIN); r = asin(a)
    case (OP_ACOS); r = acos(a)
    case (OP_ATAN); r = atan(a)
    case (OP_EXP); r = exp(a)
    case (OP_LOG); r = log(a)
    case (OP_LOG10); r = log10(a)
    case (OP_SQRT); r = sqrt(a)
    case (OP_ABS); r = abs(a)
    case (OP_SINH); r = sinh(a)
    case (OP_COSH); r = cosh(a)
    case (OP_TANH); r = tanh(a)
    case default; r = 0.0_dp
    end select
  end function apply1

  !> A binary operation a op b.  Logical values are 1 and 0; any non-zero value is true.
  elemental real(dp) function apply2(op, a, b) result(r)
    integer, intent(in) :: op
    real(dp), intent(in) :: a, b
    select case (op)
    case (OP_ADD); r = a + b
    case (OP_SUB); r = a - b
    case (OP_MUL); r = a * b
    case (OP_DIV); r = a / b
    case (OP_POW); r = a**b
    case (OP_ATAN2); r = atan2(a, b)
    case (OP_MIN); r = merge(b, a, b < a)
    case (OP_MAX); r = merge(b, a, b > a)
    case (OP_LT); r = merge(1.0_dp, 0.0_dp, a < b)
    case (OP_LE); r = merge(1.0_dp, 0.0_dp, a <= b)
    case (OP_GT); r = merge(1.0_dp, 0.0_dp, a > b)
    case (OP_GE); r = merge(1.0_dp, 0.0_dp, a >= b)
    case (OP_EQ); r = merge(1.0_dp, 0.0_dp, a == b)
    case (OP_NE); r = merge(1.0_dp, 0.0_dp, a /= b)
    case (OP_AND); r = merge(1.0_dp, 0.0_dp, a /= 0.0_dp .and. b /= 0.0_dp)
    case (OP_OR); r = merge(1.0_dp, 0.0_dp, a /= 0.0_dp .or. b /= 0.0_dp)
    case default; r = 0.0_dp
    end select
  end function apply2

  !> The derivative f'(a) of a unary operation, given a and r = f(a).
  elemental real(dp) function slope1(op, a, r, c) result(d)
    integer, intent(in) :: op
    real(dp), intent(in) :: a, r, c
    select case (op)
    case (OP_NEG); d = -1.0_dp
    case (OP_SQR); d = 2.0_dp * a
    case (OP_POWC); d = c * a**(c - 1.0_dp)
    case (OP_SIN); d = cos(a)
    case (OP_COS); d = -sin(a)
    case (OP_TAN); d = 1.0_dp + r * r
    case (OP_ASIN); d = 1.0_dp / sqrt(1.0_dp - a * a)
    case (OP_ACOS); d = -1.0_dp / sqrt(1.0_dp - a * a)
    case (OP_ATAN); d = 1.0_dp / (1.0_dp + a * a)
    case (OP_EXP); d = r
    case (OP_LOG); d = 1.0_dp / a
    case (OP_LOG10); d = 1.0_dp / (a * log(10.0_dp))
    case (OP_SQRT); d = 0.5_dp / r
    case (OP_ABS); d = merge(-1.0_dp, 1.0_dp, a < 0.0_dp)
    case (OP_SINH); d = cosh(a)
    case (OP_COSH); d = sinh(a)
    case (OP_TANH); d = 1.0_dp - r * r
    case default; d = 0.0_dp     ! not: piecewise constant
    end select
  end function slope1

  !> A binary operation on dual numbers: (a, ax, ay) := (a, ax, ay) op (b, bx, by).
  elemental subroutine dual2(op, a, ax, ay, b, bx, by)
    integer, intent(in) :: op
    real(dp), intent(inout) :: a, ax, ay
    real(dp), intent(in) :: b, bx, by
    real(dp) :: r, da, db, r2
    r = apply2(op, a, b)
    select case (op)
    case (OP_ADD)
      ax = ax + bx
      ay = ay + by
    case (OP_SUB)
      ax = ax - bx
      ay = ay - by
    case (OP_MUL)
      ax = ax * b + a * bx
      ay = ay * b + a * by
    case (OP_DIV)
      ax = (ax - r * bx) / b
      ay = (ay - r * by) / b
    case (OP_POW)
      da = b * a**(b - 1.0_dp)
      ax = da * ax
      ay = da * ay
      if (bx /= 0.0_dp .or. by /= 0.0_dp) then
        db = r * log(a)
        ax = ax + db * bx
        ay = ay + db * by
      end if
    case (OP_ATAN2)
      r2 = a * a + b * b
      ax = (b * ax - a * bx) / r2
      ay = (b * ay - a * by) / r2
    case (OP_MIN, OP_MAX)
      if ((op == OP_MIN .and. b < a) .or. (op == OP_MAX .and. b > a)) then   ! b is the active one
        ax = bx
        ay = by
      end if
    case default       ! comparisons, and, or: piecewise constant
      ax = 0.0_dp
      ay = 0.0_dp
    end select
    a = r
  end subroutine dual2

  ! ------------------------------------------------------------------ evaluation

  !> The value at one point (the same operations and bits as expression_eval).
  pure real(dp) function expression_value(expr, x, y) result(v)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: x, y
    real(dp) :: s(expr%depth)
    integer :: pc, t, op
    t = 0
    pc = 1
    do while (pc <= expr%n)
      op = expr%code(1, pc)
      select case (op)
      case (OP_CONST)
        t = t + 1
        s(t) = expr%consts(expr%code(2, pc))
      case (OP_X)
        t = t + 1
        s(t) = x
      case (OP_Y)
        t = t + 1
        s(t) = y
      case (OP_ADD)
        t = t - 1
        s(t) = s(t) + s(t + 1)
      case (OP_SUB)
        t = t - 1
        s(t) = s(t) - s(t + 1)
      case (OP_MUL)
        t = t - 1
        s(t) = s(t) * s(t + 1)
      case (OP_DIV)
        t = t - 1
        s(t) = s(t) / s(t + 1)
      case (OP_NEG)
        s(t) = -s(t)
      case (OP_SQR)
        s(t) = s(t) * s(t)
      case (OP_POWC)
        s(t) = apply1(op, s(t), expr%consts(expr%code(2, pc)))
      case (OP_IF)
        t = t - 1
        if (s(t + 1) == 0.0_dp) pc = expr%code(2, pc)         ! to the ELSE: go on after it
      case (OP_ELSE)
        pc = expr%code(2, pc)                                  ! end of the true branch: to END
      case (OP_END)
      case default
        if (is_unary(op)) then
          s(t) = apply1(op, s(t), 0.0_dp)
        else
          t = t - 1
          s(t) = apply2(op, s(t), s(t + 1))
        end if
      end select
      pc = pc + 1
    end do
    v = 0.0_dp
    if (expr%n > 0) v = s(1)
  end function expression_value

  !> Values v(i) at the points (x(i), y(i)), evaluated instruction by instruction over blocks
  !> of points.
  subroutine expression_eval(expr, x, y, v)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:)
    integer :: i0, i1
    if (expr%n == 0) then
      v = 0.0_dp
      return
    end if
    do i0 = 1, size(x), block_size
      i1 = min(size(x), i0 + block_size - 1)
      call eval_block(expr, 1, expr%n, x(i0:i1), y(i0:i1), v(i0:i1))
    end do
  end subroutine expression_eval

  !> Run instructions pc0..pc1 (a whole expression or one branch of an if) on the points.
  recursive subroutine eval_block(expr, pc0, pc1, x, y, v)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:)
    real(dp), allocatable :: s(:, :)
    logical, allocatable :: cond(:)
    integer :: pc, t, op, pelse, pend
    allocate (s(size(x), expr%depth))      ! small: one block (<= block_size points) x the stack depth
    t = 0
    pc = pc0
    do while (pc <= pc1)
      op = expr%code(1, pc)
      select case (op)
      case (OP_CONST)
        t = t + 1
        s(:, t) = expr%consts(expr%code(2, pc))
      case (OP_X)
        t = t + 1
        s(:, t) = x
      case (OP_Y)
        t = t + 1
        s(:, t) = y
      case (OP_ADD)
        t = t - 1
        s(:, t) = s(:, t) + s(:, t + 1)
      case (OP_SUB)
        t = t - 1
        s(:, t) = s(:, t) - s(:, t + 1)
      case (OP_MUL)
        t = t - 1
        s(:, t) = s(:, t) * s(:, t + 1)
      case (OP_DIV)
        t = t - 1
        s(:, t) = s(:, t) / s(:, t + 1)
      case (OP_NEG)
        s(:, t) = -s(:, t)
      case (OP_SQR)
        s(:, t) = s(:, t) * s(:, t)
      case (OP_POWC)
        s(:, t) = apply1(op, s(:, t), expr%consts(expr%code(2, pc)))
      case (OP_IF)
        pelse = expr%code(2, pc)
        pend = expr%code(2, pelse)
        cond = s(:, t) /= 0.0_dp
        call eval_branch(expr, pc + 1, pelse - 1, x, y, cond, s(:, t))
        cond = .not. cond
        call eval_branch(expr, pelse + 1, pend - 1, x, y, cond, s(:, t))
        pc = pend
      case default
        if (is_unary(op)) then
          s(:, t) = apply1(op, s(:, t), 0.0_dp)
        else
          t = t - 1
          s(:, t) = apply2(op, s(:, t), s(:, t + 1))
        end if
      end select
      pc = pc + 1
    end do
    v = s(:, 1)
  end subroutine eval_block

  !> v(i) := the branch pc0..pc1 at the points where mask(i), evaluated on those points only.
  recursive subroutine eval_branch(expr, pc0, pc1, x, y, mask, v)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    real(dp), intent(in) :: x(:), y(:)
    logical, intent(in) :: mask(:)
    real(dp), intent(inout) :: v(:)
    real(dp), allocatable :: vb(:)
    integer :: m
    m = count(mask)
    if (m == 0) return
    allocate (vb(m))                        ! small: <= block_size points
    call eval_block(expr, pc0, pc1, pack(x, mask), pack(y, mask), vb)
    v = unpack(vb, mask, v)
  end subroutine eval_branch

  !> Values and gradients at the points: v(i), gx(i) = dv/dx, gy(i) = dv/dy, by dual numbers.
  subroutine expression_eval_grad(expr, x, y, v, gx, gy)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:), gx(:), gy(:)
    integer :: i0, i1
    if (expr%n == 0) then
      v = 0.0_dp
      gx = 0.0_dp
      gy = 0.0_dp
      return
    end if
    do i0 = 1, size(x), block_size
      i1 = min(size(x), i0 + block_size - 1)
      call dual_block(expr, 1, expr%n, x(i0:i1), y(i0:i1), v(i0:i1), gx(i0:i1), gy(i0:i1))
    end do
  end subroutine expression_eval_grad

  !> Value v and gradient g = (dv/dx, dv/dy) at one point.
  subroutine expression_value_grad(expr, x, y, v, g)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: x, y
    real(dp), intent(out) :: v, g(2)
    real(dp) :: va(1), gx(1), gy(1)
    call expression_eval_grad(expr, [x], [y], va, gx, gy)
    v = va(1)
    g = [gx(1), gy(1)]
  end subroutine expression_value_grad

  !> eval_block on dual numbers: values s, d/dx sx, d/dy sy.
  recursive subroutine dual_block(expr, pc0, pc1, x, y, v, gx, gy)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:), gx(:), gy(:)
    real(dp), allocatable :: s(:, :), sx(:, :), sy(:, :), r(:)
    logical, allocatable :: cond(:)
    integer :: pc, t, op, pelse, pend
    real(dp) :: c
    allocate (s(size(x), expr%depth), sx(size(x), expr%depth), sy(size(x), expr%depth))  ! small: as in eval_block
    t = 0
    pc = pc0
    do while (pc <= pc1)
      op = expr%code(1, pc)
      select case (op)
      case (OP_CONST, OP_X, OP_Y)
        t = t + 1
        sx(:, t) = merge(1.0_dp, 0.0_dp, op == OP_X)
        sy(:, t) = merge(1.0_dp, 0.0_dp, op == OP_Y)
        if (op == OP_CONST) s(:, t) = expr%consts(expr%code(2, pc))
        if (op == OP_X) s(:, t) = x
        if (op == OP_Y) s(:, t) = y
      case (OP_IF)
        pelse = expr%code(2, pc)
        pend = expr%code(2, pelse)
        cond = s(:, t) /= 0.0_dp
        call dual_branch(expr, pc + 1, pelse - 1, x, y, cond, s(:, t), sx(:, t), sy(:, t))
        cond = .not. cond
        call dual_branch(expr, pelse + 1, pend - 1, x, y, cond, s(:, t), sx(:, t), sy(:, t))
        pc = pend
      case default
        if (is_unary(op) .or. op == OP_POWC) then
          c = 0.0_dp
          if (op == OP_POWC) c = expr%consts(expr%code(2, pc))
          r = apply1(op, s(:, t), c)
          s(:, t) = slope1(op, s(:, t), r, c)
          sx(:, t) = s(:, t) * sx(:, t)
          sy(:, t) = s(:, t) * sy(:, t)
          s(:, t) = r
        else
          t = t - 1
          call dual2(op, s(:, t), sx(:, t), sy(:, t), s(:, t + 1), sx(:, t + 1), sy(:, t + 1))
        end if
      end select
      pc = pc + 1
    end do
    v = s(:, 1)
    gx = sx(:, 1)
    gy = sy(:, 1)
  end subroutine dual_block

  !> dual_block of one branch of an if, at the points where mask(i) only.
  recursive subroutine dual_branch(expr, pc0, pc1, x, y, mask, v, gx, gy)
    type(expression_t), intent(in) :: expr
    integer, intent(in) :: pc0, pc1
    real(dp), intent(in) :: x(:), y(:)
    logical, intent(in) :: mask(:)
    real(dp), intent(inout) :: v(:), gx(:), gy(:)
    real(dp), allocatable :: vb(:), gxb(:), gyb(:)
    integer :: m
    m = count(mask)
    if (m == 0) return
    allocate (vb(m), gxb(m), gyb(m))        ! small: <= block_size points
    call dual_block(expr, pc0, pc1, pack(x, mask), pack(y, mask), vb, gxb, gyb)
    v = unpack(vb, mask, v)
    gx = unpack(gxb, mask, gx)
    gy = unpack(gyb, mask, gy)
  end subroutine dual_branch

  !> The first point where the value (and, with gradient = .true., the gradient) is not
  !> finite: ok = .false. and ipoint its index; ok = .true. and ipoint = 0 when there is
  !> none.  Evaluates with floating-point traps disarmed and restores the floating-point
  !> status afterwards.
  subroutine expression_check_finite(expr, x, y, ok, ipoint, gradient, st)
    type(expression_t), intent(in) :: expr
    real(dp), intent(in) :: x(:), y(:)
    logical, intent(out) :: ok
    integer, intent(out) :: ipoint
    logical, intent(in), optional :: gradient
    type(status_t), intent(inout) :: st  !! out of memory: ok, DS_ERR_MEMORY (see dualsig_alloc)
    type(ieee_status_type) :: saved
    real(dp), allocatable :: v(:), gx(:), gy(:)
    logical :: with_gradient
    integer :: i, ist
    with_gradient = .false.
    if (present(gradient)) with_gradient = gradient
    ok = .true.
    ipoint = 0
    allocate (v(size(x)), gx(merge(size(x), 0, with_gradient)), gy(merge(size(x), 0, with_gradient)), stat=ist)
    if (alloc_failed(ist, st, 'the values of an expression', 3 * size(x), BYTES_REAL)) return
    call ieee_get_status(saved)
    call ieee_set_halting_mode(ieee_usual, .false.)
    if (with_gradient) then
      call expression_eval_grad(expr, x, y, v, gx, gy)
    else
      call expression_eval(expr, x, y, v)
    end if
    ipoint = 0
    do i = 1, size(x)
      if (.not. ieee_is_finite(v(i))) ipoint = i
      if (with_gradient .and. ipoint == 0) then
        if (.not. (ieee_is_finite(gx(i)) .and. ieee_is_finite(gy(i)))) ipoint = i
      end if
      if (ipoint /= 0) exit
    end do
    call ieee_set_status(saved)
    ok = ipoint == 0
  end subroutine expression_check_finite
end module dualsig_expression
