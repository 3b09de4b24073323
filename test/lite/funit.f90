!> funit -- run-time half of pfunit_lite, the fallback for pFUnit 4 (see test/pfunit_lite.py).
!>
!> The translated .pf files call the generic assertion procedures below; each failed assertion
!> records one message (".pf file:line: assertXxx failed: details: user message") and raises the
!> failure flag that the translated code tests right after the call (`if (funit_failed()) return`),
!> so a test returns at its first failed assertion, as under pFUnit.  The generated main program
!> runs every test through funit_run_test and ends with funit_finish.
!>
!> Only argument combinations that pFUnit 4 also accepts are provided, so that a test compiling
!> here also compiles under real pFUnit:
!>   assertEqual  integer (default or int64; expected default or same kind) scalar/rank-1, with
!>                `message=` by keyword only;
!>                real(real64) actual, expected integer, default real or real64, scalar or rank-1
!>                (scalar expected against rank-1 actual is allowed), optional tolerance (default
!>                real or real64, absolute, |actual - expected| <= tolerance; exact without it);
!>                logical scalar/rank-1 (`message=` by keyword only); character scalar
!>                (leading and trailing blanks ignored, as pFUnit's default TRIM_ALL).
!>   assertTrue/assertFalse  logical scalar or rank-1 (all elements).
!>   assertLessThan[OrEqual], assertGreaterThan[OrEqual]  scalars: integer (as assertEqual, with
!>                `message=` by keyword only) or a real(real64) right-hand side with an integer,
!>                default real or real64 left-hand side.
!>   assertIsFinite  real(real64) scalar (pFUnit 4 has no array form).
module funit
   use, intrinsic :: iso_fortran_env, only: real64, int64, output_unit
   use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_is_finite, ieee_value, ieee_positive_inf
   implicit none
   private

   public :: funit_assert_equal
   public :: funit_assert_true, funit_assert_false
   public :: funit_assert_less_than, funit_assert_less_than_or_equal
   public :: funit_assert_greater_than, funit_assert_greater_than_or_equal
   public :: funit_assert_is_finite
   public :: funit_failed
   public :: funit_run_test, funit_finish

   !> A dummy argument of this private type (which no caller can name) sits in front of the
   !> optional arguments where pFUnit has its KeywordEnforcer, so `message` must be given by
   !> keyword there, as with pFUnit.
   type :: keyword_enforcer
   end type keyword_enforcer

   !> Interface of test, @before and @after procedures.
   abstract interface
      subroutine test_procedure()
      end subroutine test_procedure
   end interface

   type :: text_t
      character(len=:), allocatable :: s
   end type text_t

   ! Operators of the ordering assertions.
   integer, parameter :: op_lt = 1, op_le = 2, op_gt = 3, op_ge = 4
   character(len=*), parameter :: op_name(4) = [character(len=24) :: 'assertLessThan', &
        'assertLessThanOrEqual', 'assertGreaterThan', 'assertGreaterThanOrEqual']
   character(len=*), parameter :: op_words(4) = [character(len=24) :: 'less than', &
        'less than or equal to', 'greater than', 'greater than or equal to']

   !> At most this many failure messages are printed for one test.
   integer, parameter :: max_printed = 20

   ! Bookkeeping of the running test and of the whole run.
   type(text_t), allocatable :: failures(:)     ! messages recorded for the running test
   integer :: n_failures = 0
   logical :: phase_failed = .false.            ! a failure in the current phase (@before, test, @after)
   integer :: n_passed = 0, n_failed = 0
   logical :: filter_read = .false., have_filter = .false.
   character(len=:), allocatable :: filter

   interface funit_assert_equal
      module procedure equal_i4s_i4s, equal_i4s_i4v, equal_i4v_i4v
      module procedure equal_i8s_i8s, equal_i8s_i8v, equal_i8v_i8v
      module procedure equal_i4s_i8s, equal_i4s_i8v, equal_i4v_i8v
      module procedure equal_i4s_r8s, equal_i4s_r8s_tol4, equal_i4s_r8s_tol8
      module procedure equal_i4s_r8v, equal_i4s_r8v_tol4, equal_i4s_r8v_tol8
      module procedure equal_i4v_r8v, equal_i4v_r8v_tol4, equal_i4v_r8v_tol8
      module procedure equal_r4s_r8s, equal_r4s_r8s_tol4, equal_r4s_r8s_tol8
      module procedure equal_r4s_r8v, equal_r4s_r8v_tol4, equal_r4s_r8v_tol8
      module procedure equal_r4v_r8v, equal_r4v_r8v_tol4, equal_r4v_r8v_tol8
      module procedure equal_r8s_r8s, equal_r8s_r8s_tol4, equal_r8s_r8s_tol8
      module procedure equal_r8s_r8v, equal_r8s_r8v_tol4, equal_r8s_r8v_tol8
      module procedure equal_r8v_r8v, equal_r8v_r8v_tol4, equal_r8v_r8v_tol8
      module procedure equal_ls_ls, equal_ls_lv, equal_lv_lv
      module procedure equal_cs_cs
   end interface funit_assert_equal

   interface funit_assert_true
      module procedure true_s, true_v
   end interface funit_assert_true

   interface funit_assert_false
      module procedure false_s, false_v
   end interface funit_assert_false

   interface funit_assert_less_than
      module procedure lt_i4_i4, lt_i8_i8, lt_i4_i8
      module procedure lt_i4_r8, lt_r4_r8, lt_r8_r8
   end interface funit_assert_less_than

   interface funit_assert_less_than_or_equal
      module procedure le_i4_i4, le_i8_i8, le_i4_i8
      module procedure le_i4_r8, le_r4_r8, le_r8_r8
   end interface funit_assert_less_than_or_equal

   interface funit_assert_greater_than
      module procedure gt_i4_i4, gt_i8_i8, gt_i4_i8
      module procedure gt_i4_r8, gt_r4_r8, gt_r8_r8
   end interface funit_assert_greater_than

   interface funit_assert_greater_than_or_equal
      module procedure ge_i4_i4, ge_i8_i8, ge_i4_i8
      module procedure ge_i4_r8, ge_r4_r8, ge_r8_r8
   end interface funit_assert_greater_than_or_equal

   interface funit_assert_is_finite
      module procedure is_finite_r8
   end interface funit_assert_is_finite

   interface istr
      module procedure istr_default, istr_int64
   end interface istr

contains

   ! ------------------------------------------------------------------ runner

   !> True when the current phase (@before, test body or @after) of the running test has a failed
   !> assertion; the translated code returns from the procedure then.
   logical function funit_failed()
      funit_failed = phase_failed
   end function funit_failed

   !> Run one test: @before (if any), the test unless @before failed, @after (if any); then print
   !> " ok    module::test" or " FAIL  module::test" and the failure messages.  Skipped
   !> silently when PFUNIT_LITE_FILTER is set and `name` does not contain it.
   subroutine funit_run_test(name, test, before, after)
      character(len=*), intent(in) :: name
      procedure(test_procedure) :: test
      procedure(test_procedure), optional :: before, after
      integer :: i

      if (.not. selected(name)) return
      n_failures = 0
      phase_failed = .false.
      if (present(before)) call before()
      if (phase_failed) then
         call push_failure('@before failed, test body not run')
      else
         call test()
      end if
      phase_failed = .false.
      if (present(after)) call after()
      phase_failed = .false.

      if (n_failures == 0) then
         n_passed = n_passed + 1
         write(output_unit, '(a)') ' ok    ' // name
      else
         n_failed = n_failed + 1
         write(output_unit, '(a)') ' FAIL  ' // name
         do i = 1, min(n_failures, max_printed)
            write(output_unit, '(a)') '        ' // failures(i)%s
         end do
         if (n_failures > max_printed) then
            write(output_unit, '(a)') '        ... and ' // istr(n_failures - max_printed) // ' more failures'
         end if
      end if
      flush(output_unit)
   end subroutine funit_run_test

   !> Print the summary line "N passed, M failed" as the last line and stop with exit status 1
   !> if a test failed (quietly: nothing is written after the summary line).
   subroutine funit_finish()
      call read_filter()
      if (have_filter .and. n_passed + n_failed == 0) then
         write(output_unit, '(a)') 'no test name contains PFUNIT_LITE_FILTER="' // filter // '"'
      end if
      write(output_unit, '(a)') istr(n_passed) // ' passed, ' // istr(n_failed) // ' failed'
      flush(output_unit)
      ! Not ERROR STOP: with -fbacktrace gfortran prints a backtrace on ERROR STOP even with QUIET.
      if (n_failed > 0) stop 1, quiet=.true.
   end subroutine funit_finish

   logical function selected(name)
      character(len=*), intent(in) :: name
      call read_filter()
      selected = .true.
      if (have_filter) selected = index(name, filter) > 0
   end function selected

   subroutine read_filter()
      integer :: length, status
      if (filter_read) return
      filter_read = .true.
      call get_environment_variable('PFUNIT_LITE_FILTER', length=length, status=status)
      have_filter = status == 0
      if (.not. have_filter) return
      allocate(character(len=length) :: filter)
      if (length > 0) call get_environment_variable('PFUNIT_LITE_FILTER', value=filter)
   end subroutine read_filter

   !> Record a failure of the running test.
   subroutine push_failure(text)
      character(len=*), intent(in) :: text
      type(text_t), allocatable :: grown(:)
      if (.not. allocated(failures)) allocate(failures(8))
      if (n_failures == size(failures)) then
         allocate(grown(2*size(failures)))
         grown(1:n_failures) = failures(1:n_failures)
         call move_alloc(grown, failures)
      end if
      n_failures = n_failures + 1
      failures(n_failures)%s = text
   end subroutine push_failure

   !> Record a failed assertion: "location: what failed[: details][: message]".
   subroutine fail(what, details, message, location)
      character(len=*), intent(in) :: what, details
      character(len=*), intent(in), optional :: message, location
      character(len=:), allocatable :: text
      text = ''
      if (present(location)) text = location // ': '
      text = text // what // ' failed'
      if (len(details) > 0) text = text // ': ' // details
      if (present(message)) then
         if (len_trim(message) > 0) text = text // ': ' // trim(message)
      end if
      call push_failure(text)
      phase_failed = .true.
   end subroutine fail

   ! ------------------------------------------------------------------ assertEqual specifics

   subroutine equal_i4s_i4s(expected, actual, unused, message, location)
      integer, intent(in) :: expected
      integer, intent(in) :: actual
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([int(expected, int64)], [int(actual, int64)], .false., .true., message, location)
   end subroutine equal_i4s_i4s

   subroutine equal_i4s_i4v(expected, actual, unused, message, location)
      integer, intent(in) :: expected
      integer, intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([int(expected, int64)], int(actual, int64), .true., .false., message, location)
   end subroutine equal_i4s_i4v

   subroutine equal_i4v_i4v(expected, actual, unused, message, location)
      integer, intent(in) :: expected(:)
      integer, intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal(int(expected, int64), int(actual, int64), .false., .false., message, location)
   end subroutine equal_i4v_i4v

   subroutine equal_i8s_i8s(expected, actual, unused, message, location)
      integer(int64), intent(in) :: expected
      integer(int64), intent(in) :: actual
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([expected], [actual], .false., .true., message, location)
   end subroutine equal_i8s_i8s

   subroutine equal_i8s_i8v(expected, actual, unused, message, location)
      integer(int64), intent(in) :: expected
      integer(int64), intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([expected], actual, .true., .false., message, location)
   end subroutine equal_i8s_i8v

   subroutine equal_i8v_i8v(expected, actual, unused, message, location)
      integer(int64), intent(in) :: expected(:)
      integer(int64), intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal(expected, actual, .false., .false., message, location)
   end subroutine equal_i8v_i8v

   subroutine equal_i4s_i8s(expected, actual, unused, message, location)
      integer, intent(in) :: expected
      integer(int64), intent(in) :: actual
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([int(expected, int64)], [actual], .false., .true., message, location)
   end subroutine equal_i4s_i8s

   subroutine equal_i4s_i8v(expected, actual, unused, message, location)
      integer, intent(in) :: expected
      integer(int64), intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal([int(expected, int64)], actual, .true., .false., message, location)
   end subroutine equal_i4s_i8v

   subroutine equal_i4v_i8v(expected, actual, unused, message, location)
      integer, intent(in) :: expected(:)
      integer(int64), intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_equal(int(expected, int64), actual, .false., .false., message, location)
   end subroutine equal_i4v_i8v

   subroutine equal_i4s_r8s(expected, actual, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location)
   end subroutine equal_i4s_r8s

   subroutine equal_i4s_r8s_tol4(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location, real(tolerance, real64))
   end subroutine equal_i4s_r8s_tol4

   subroutine equal_i4s_r8s_tol8(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location, tolerance)
   end subroutine equal_i4s_r8s_tol8

   subroutine equal_i4s_r8v(expected, actual, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location)
   end subroutine equal_i4s_r8v

   subroutine equal_i4s_r8v_tol4(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location, real(tolerance, real64))
   end subroutine equal_i4s_r8v_tol4

   subroutine equal_i4s_r8v_tol8(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location, tolerance)
   end subroutine equal_i4s_r8v_tol8

   subroutine equal_i4v_r8v(expected, actual, message, location)
      integer, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location)
   end subroutine equal_i4v_r8v

   subroutine equal_i4v_r8v_tol4(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location, real(tolerance, real64))
   end subroutine equal_i4v_r8v_tol4

   subroutine equal_i4v_r8v_tol8(expected, actual, tolerance, message, location)
      integer, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location, tolerance)
   end subroutine equal_i4v_r8v_tol8

   subroutine equal_r4s_r8s(expected, actual, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location)
   end subroutine equal_r4s_r8s

   subroutine equal_r4s_r8s_tol4(expected, actual, tolerance, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location, real(tolerance, real64))
   end subroutine equal_r4s_r8s_tol4

   subroutine equal_r4s_r8s_tol8(expected, actual, tolerance, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], [actual], .false., .true., message, location, tolerance)
   end subroutine equal_r4s_r8s_tol8

   subroutine equal_r4s_r8v(expected, actual, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location)
   end subroutine equal_r4s_r8v

   subroutine equal_r4s_r8v_tol4(expected, actual, tolerance, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location, real(tolerance, real64))
   end subroutine equal_r4s_r8v_tol4

   subroutine equal_r4s_r8v_tol8(expected, actual, tolerance, message, location)
      real, intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([real(expected, real64)], actual, .true., .false., message, location, tolerance)
   end subroutine equal_r4s_r8v_tol8

   subroutine equal_r4v_r8v(expected, actual, message, location)
      real, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location)
   end subroutine equal_r4v_r8v

   subroutine equal_r4v_r8v_tol4(expected, actual, tolerance, message, location)
      real, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location, real(tolerance, real64))
   end subroutine equal_r4v_r8v_tol4

   subroutine equal_r4v_r8v_tol8(expected, actual, tolerance, message, location)
      real, intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(real(expected, real64), actual, .false., .false., message, location, tolerance)
   end subroutine equal_r4v_r8v_tol8

   subroutine equal_r8s_r8s(expected, actual, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], [actual], .false., .true., message, location)
   end subroutine equal_r8s_r8s

   subroutine equal_r8s_r8s_tol4(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], [actual], .false., .true., message, location, real(tolerance, real64))
   end subroutine equal_r8s_r8s_tol4

   subroutine equal_r8s_r8s_tol8(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], [actual], .false., .true., message, location, tolerance)
   end subroutine equal_r8s_r8s_tol8

   subroutine equal_r8s_r8v(expected, actual, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], actual, .true., .false., message, location)
   end subroutine equal_r8s_r8v

   subroutine equal_r8s_r8v_tol4(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], actual, .true., .false., message, location, real(tolerance, real64))
   end subroutine equal_r8s_r8v_tol4

   subroutine equal_r8s_r8v_tol8(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal([expected], actual, .true., .false., message, location, tolerance)
   end subroutine equal_r8s_r8v_tol8

   subroutine equal_r8v_r8v(expected, actual, message, location)
      real(real64), intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      character(len=*), intent(in), optional :: message, location
      call real_equal(expected, actual, .false., .false., message, location)
   end subroutine equal_r8v_r8v

   subroutine equal_r8v_r8v_tol4(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real, intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(expected, actual, .false., .false., message, location, real(tolerance, real64))
   end subroutine equal_r8v_r8v_tol4

   subroutine equal_r8v_r8v_tol8(expected, actual, tolerance, message, location)
      real(real64), intent(in) :: expected(:)
      real(real64), intent(in) :: actual(:)
      real(real64), intent(in) :: tolerance
      character(len=*), intent(in), optional :: message, location
      call real_equal(expected, actual, .false., .false., message, location, tolerance)
   end subroutine equal_r8v_r8v_tol8

   subroutine equal_ls_ls(expected, actual, unused, message, location)
      logical, intent(in) :: expected
      logical, intent(in) :: actual
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call logical_equal([expected], [actual], .false., .true., message, location)
   end subroutine equal_ls_ls

   subroutine equal_ls_lv(expected, actual, unused, message, location)
      logical, intent(in) :: expected
      logical, intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call logical_equal([expected], actual, .true., .false., message, location)
   end subroutine equal_ls_lv

   subroutine equal_lv_lv(expected, actual, unused, message, location)
      logical, intent(in) :: expected(:)
      logical, intent(in) :: actual(:)
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call logical_equal(expected, actual, .false., .false., message, location)
   end subroutine equal_lv_lv

   !> Strings are compared without leading and trailing blanks and tabs (pFUnit's TRIM_ALL).
   subroutine equal_cs_cs(expected, actual, message, location)
      character(len=*), intent(in) :: expected
      character(len=*), intent(in) :: actual
      character(len=*), intent(in), optional :: message, location
      character(len=:), allocatable :: e, a
      e = strip(expected)
      a = strip(actual)
      if (len(e) == len(a)) then
         if (e == a) return
      end if
      call fail('assertEqual', 'expected "' // e // '" but found "' // a // '"', message, location)
   end subroutine equal_cs_cs

   ! ------------------------------------------------------------------ ordering specifics

   subroutine lt_i4_i4(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer, intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), int(rhs, int64), op_lt, message, location)
   end subroutine lt_i4_i4

   subroutine lt_i8_i8(lhs, rhs, unused, message, location)
      integer(int64), intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(lhs, rhs, op_lt, message, location)
   end subroutine lt_i8_i8

   subroutine lt_i4_i8(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), rhs, op_lt, message, location)
   end subroutine lt_i4_i8

   subroutine lt_i4_r8(lhs, rhs, message, location)
      integer, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_lt, message, location)
   end subroutine lt_i4_r8

   subroutine lt_r4_r8(lhs, rhs, message, location)
      real, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_lt, message, location)
   end subroutine lt_r4_r8

   subroutine lt_r8_r8(lhs, rhs, message, location)
      real(real64), intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(lhs, rhs, op_lt, message, location)
   end subroutine lt_r8_r8

   subroutine le_i4_i4(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer, intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), int(rhs, int64), op_le, message, location)
   end subroutine le_i4_i4

   subroutine le_i8_i8(lhs, rhs, unused, message, location)
      integer(int64), intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(lhs, rhs, op_le, message, location)
   end subroutine le_i8_i8

   subroutine le_i4_i8(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), rhs, op_le, message, location)
   end subroutine le_i4_i8

   subroutine le_i4_r8(lhs, rhs, message, location)
      integer, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_le, message, location)
   end subroutine le_i4_r8

   subroutine le_r4_r8(lhs, rhs, message, location)
      real, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_le, message, location)
   end subroutine le_r4_r8

   subroutine le_r8_r8(lhs, rhs, message, location)
      real(real64), intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(lhs, rhs, op_le, message, location)
   end subroutine le_r8_r8

   subroutine gt_i4_i4(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer, intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), int(rhs, int64), op_gt, message, location)
   end subroutine gt_i4_i4

   subroutine gt_i8_i8(lhs, rhs, unused, message, location)
      integer(int64), intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(lhs, rhs, op_gt, message, location)
   end subroutine gt_i8_i8

   subroutine gt_i4_i8(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), rhs, op_gt, message, location)
   end subroutine gt_i4_i8

   subroutine gt_i4_r8(lhs, rhs, message, location)
      integer, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_gt, message, location)
   end subroutine gt_i4_r8

   subroutine gt_r4_r8(lhs, rhs, message, location)
      real, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_gt, message, location)
   end subroutine gt_r4_r8

   subroutine gt_r8_r8(lhs, rhs, message, location)
      real(real64), intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(lhs, rhs, op_gt, message, location)
   end subroutine gt_r8_r8

   subroutine ge_i4_i4(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer, intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), int(rhs, int64), op_ge, message, location)
   end subroutine ge_i4_i4

   subroutine ge_i8_i8(lhs, rhs, unused, message, location)
      integer(int64), intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(lhs, rhs, op_ge, message, location)
   end subroutine ge_i8_i8

   subroutine ge_i4_i8(lhs, rhs, unused, message, location)
      integer, intent(in) :: lhs
      integer(int64), intent(in) :: rhs
      type(keyword_enforcer), intent(in), optional :: unused
      character(len=*), intent(in), optional :: message, location
      if (present(unused)) continue
      call integer_order(int(lhs, int64), rhs, op_ge, message, location)
   end subroutine ge_i4_i8

   subroutine ge_i4_r8(lhs, rhs, message, location)
      integer, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_ge, message, location)
   end subroutine ge_i4_r8

   subroutine ge_r4_r8(lhs, rhs, message, location)
      real, intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(real(lhs, real64), rhs, op_ge, message, location)
   end subroutine ge_r4_r8

   subroutine ge_r8_r8(lhs, rhs, message, location)
      real(real64), intent(in) :: lhs
      real(real64), intent(in) :: rhs
      character(len=*), intent(in), optional :: message, location
      call real_order(lhs, rhs, op_ge, message, location)
   end subroutine ge_r8_r8

   ! ------------------------------------------------------------------ assertTrue, assertFalse, assertIsFinite

   !> `expression` is the source text of the condition, supplied by the translator.
   subroutine true_s(condition, message, location, expression)
      logical, intent(in) :: condition
      character(len=*), intent(in), optional :: message, location, expression
      call truth([condition], .true., .true., message, location, expression)
   end subroutine true_s

   subroutine true_v(condition, message, location, expression)
      logical, intent(in) :: condition(:)
      character(len=*), intent(in), optional :: message, location, expression
      call truth(condition, .true., .false., message, location, expression)
   end subroutine true_v

   subroutine false_s(condition, message, location, expression)
      logical, intent(in) :: condition
      character(len=*), intent(in), optional :: message, location, expression
      call truth([condition], .false., .true., message, location, expression)
   end subroutine false_s

   subroutine false_v(condition, message, location, expression)
      logical, intent(in) :: condition(:)
      character(len=*), intent(in), optional :: message, location, expression
      call truth(condition, .false., .false., message, location, expression)
   end subroutine false_v

   subroutine is_finite_r8(x, message, location)
      real(real64), intent(in) :: x
      character(len=*), intent(in), optional :: message, location
      if (ieee_is_finite(x)) return
      call fail('assertIsFinite', 'found ' // rstr(x), message, location)
   end subroutine is_finite_r8

   ! ------------------------------------------------------------------ comparisons

   !> Element-wise integer equality; a single expected value is compared with every element if
   !> `broadcast`; `scalar` selects the message form without an index.
   subroutine integer_equal(e, a, broadcast, scalar, message, location)
      integer(int64), intent(in) :: e(:), a(:)
      logical, intent(in) :: broadcast, scalar
      character(len=*), intent(in), optional :: message, location
      integer :: i, first, n_bad
      integer(int64) :: ei

      if (.not. broadcast .and. size(e) /= size(a)) then
         call fail('assertEqual', shape_text(size(e), size(a)), message, location)
         return
      end if
      first = 0
      n_bad = 0
      do i = 1, size(a)
         ei = e(1)
         if (.not. broadcast) ei = e(i)
         if (ei /= a(i)) then
            n_bad = n_bad + 1
            if (first == 0) first = i
         end if
      end do
      if (n_bad == 0) return
      ei = e(1)
      if (.not. broadcast) ei = e(first)
      call fail('assertEqual', 'expected ' // istr(ei) // ' but found ' // istr(a(first)) &
           // index_text(scalar, first, n_bad, size(a)), message, location)
   end subroutine integer_equal

   !> Element-wise real equality: |a - e| <= tol (tol = 0 when absent, i.e. exact); NaN never
   !> equals anything, equal infinities are equal.
   subroutine real_equal(e, a, broadcast, scalar, message, location, tol)
      real(real64), intent(in) :: e(:), a(:)
      logical, intent(in) :: broadcast, scalar
      character(len=*), intent(in), optional :: message, location
      real(real64), intent(in), optional :: tol
      integer :: i, first, n_bad
      real(real64) :: ei, t
      character(len=:), allocatable :: details

      t = 0.0_real64
      if (present(tol)) t = tol
      if (.not. broadcast .and. size(e) /= size(a)) then
         call fail('assertEqual', shape_text(size(e), size(a)), message, location)
         return
      end if
      first = 0
      n_bad = 0
      do i = 1, size(a)
         ei = e(1)
         if (.not. broadcast) ei = e(i)
         if (.not. within(ei, a(i), t)) then
            n_bad = n_bad + 1
            if (first == 0) first = i
         end if
      end do
      if (n_bad == 0) return
      ei = e(1)
      if (.not. broadcast) ei = e(first)
      details = 'expected ' // rstr(ei) // ' but found ' // rstr(a(first)) &
           // index_text(scalar, first, n_bad, size(a)) // ' ('
      if (ieee_is_finite(ei) .and. ieee_is_finite(a(first))) then
         details = details // 'difference ' // rstr(abs_difference(ei, a(first))) // ', '
      end if
      if (present(tol)) then
         details = details // 'tolerance ' // rstr(t) // ')'
      else
         details = details // 'exact comparison)'
      end if
      call fail('assertEqual', details, message, location)
   end subroutine real_equal

   subroutine logical_equal(e, a, broadcast, scalar, message, location)
      logical, intent(in) :: e(:), a(:)
      logical, intent(in) :: broadcast, scalar
      character(len=*), intent(in), optional :: message, location
      integer :: i, first, n_bad
      logical :: ei

      if (.not. broadcast .and. size(e) /= size(a)) then
         call fail('assertEqual', shape_text(size(e), size(a)), message, location)
         return
      end if
      first = 0
      n_bad = 0
      do i = 1, size(a)
         ei = e(1)
         if (.not. broadcast) ei = e(i)
         if (ei .neqv. a(i)) then
            n_bad = n_bad + 1
            if (first == 0) first = i
         end if
      end do
      if (n_bad == 0) return
      ei = e(1)
      if (.not. broadcast) ei = e(first)
      call fail('assertEqual', 'expected ' // lstr(ei) // ' but found ' // lstr(a(first)) &
           // index_text(scalar, first, n_bad, size(a)), message, location)
   end subroutine logical_equal

   subroutine integer_order(l, r, op, message, location)
      integer(int64), intent(in) :: l, r
      integer, intent(in) :: op
      character(len=*), intent(in), optional :: message, location
      logical :: ok
      select case (op)
      case (op_lt)
         ok = l < r
      case (op_le)
         ok = l <= r
      case (op_gt)
         ok = l > r
      case default
         ok = l >= r
      end select
      if (ok) return
      call fail(trim(op_name(op)), istr(l) // ' is not ' // trim(op_words(op)) // ' ' // istr(r), &
           message, location)
   end subroutine integer_order

   !> Ordering of reals; false whenever an operand is NaN (tested first, so that no ordered
   !> comparison with a NaN is executed under -ffpe-trap=invalid).
   subroutine real_order(l, r, op, message, location)
      real(real64), intent(in) :: l, r
      integer, intent(in) :: op
      character(len=*), intent(in), optional :: message, location
      logical :: ok
      if (ieee_is_nan(l) .or. ieee_is_nan(r)) then
         ok = .false.
      else
         select case (op)
         case (op_lt)
            ok = l < r
         case (op_le)
            ok = l <= r
         case (op_gt)
            ok = l > r
         case default
            ok = l >= r
         end select
      end if
      if (ok) return
      call fail(trim(op_name(op)), rstr(l) // ' is not ' // trim(op_words(op)) // ' ' // rstr(r), &
           message, location)
   end subroutine real_order

   subroutine truth(condition, wanted, scalar, message, location, expression)
      logical, intent(in) :: condition(:)
      logical, intent(in) :: wanted, scalar
      character(len=*), intent(in), optional :: message, location, expression
      character(len=:), allocatable :: what, details
      integer :: i, first, n_bad

      first = 0
      n_bad = 0
      do i = 1, size(condition)
         if (condition(i) .neqv. wanted) then
            n_bad = n_bad + 1
            if (first == 0) first = i
         end if
      end do
      if (n_bad == 0) return
      what = 'assertTrue'
      if (.not. wanted) what = 'assertFalse'
      details = ''
      if (present(expression)) details = expression // ' is ' // lstr(.not. wanted)
      if (.not. scalar) then
         if (present(expression)) details = details // ' at'
         details = details // ' index ' // istr(first) // ' (' // istr(n_bad) // ' of ' &
              // istr(size(condition)) // ' elements)'
      end if
      call fail(what, trim(adjustl(details)), message, location)
   end subroutine truth

   ! ------------------------------------------------------------------ helpers

   !> |a - e| <= tol for finite, non-NaN values; computed without overflow or invalid operations.
   logical function within(e, a, tol)
      real(real64), intent(in) :: e, a, tol
      within = .false.
      if (ieee_is_nan(e) .or. ieee_is_nan(a) .or. ieee_is_nan(tol)) return
      if (e == a) then
         within = .true.
         return
      end if
      if (.not. (ieee_is_finite(e) .and. ieee_is_finite(a))) return
      within = abs_difference(e, a) <= tol
   end function within

   !> |a - e| for finite e and a, computed without overflow: +Infinity if it exceeds huge().
   real(real64) function abs_difference(e, a)
      real(real64), intent(in) :: e, a
      real(real64) :: half
      if (abs(e) <= 0.5_real64*huge(e) .and. abs(a) <= 0.5_real64*huge(a)) then
         abs_difference = abs(a - e)
      else
         half = abs(0.5_real64*a - 0.5_real64*e)
         if (half > 0.5_real64*huge(e)) then
            abs_difference = ieee_value(e, ieee_positive_inf)
         else
            abs_difference = 2.0_real64*half
         end if
      end if
   end function abs_difference

   function shape_text(n_expected, n_actual) result(s)
      integer, intent(in) :: n_expected, n_actual
      character(len=:), allocatable :: s
      s = 'shapes differ: expected size ' // istr(n_expected) // ' but found size ' // istr(n_actual)
   end function shape_text

   function index_text(scalar, first, n_bad, n) result(s)
      logical, intent(in) :: scalar
      integer, intent(in) :: first, n_bad, n
      character(len=:), allocatable :: s
      s = ''
      if (.not. scalar) s = ' at index ' // istr(first) // ' (' // istr(n_bad) // ' of ' // istr(n) &
           // ' elements differ)'
   end function index_text

   function istr_default(i) result(s)
      integer, intent(in) :: i
      character(len=:), allocatable :: s
      character(len=24) :: buffer
      write(buffer, '(i0)') i
      s = trim(buffer)
   end function istr_default

   function istr_int64(i) result(s)
      integer(int64), intent(in) :: i
      character(len=:), allocatable :: s
      character(len=24) :: buffer
      write(buffer, '(i0)') i
      s = trim(buffer)
   end function istr_int64

   !> Shortest decimal form (at most 17 significant digits) that reads back as x: fixed point
   !> for 1e-4 <= |x| < 1e15, otherwise scientific.
   function rstr(x) result(s)
      real(real64), intent(in) :: x
      character(len=:), allocatable :: s
      character(len=64) :: buffer
      character(len=12) :: form
      real(real64) :: y
      integer :: digits, status
      if (ieee_is_nan(x)) then
         s = 'NaN'
         return
      else if (.not. ieee_is_finite(x)) then
         s = '-Infinity'
         if (x > 0.0_real64) s = '+Infinity'
         return
      else if (x == 0.0_real64) then
         s = '0.0'
         return
      end if
      if (abs(x) >= 1.0e-4_real64 .and. abs(x) < 1.0e15_real64) then
         do digits = 1, 24
            write(form, '(a, i0, a)') '(f0.', digits, ')'
            write(buffer, form) x
            read(buffer, *, iostat=status) y
            if (status == 0 .and. y == x) exit
         end do
         s = trim(adjustl(buffer))
         if (s(1:1) == '.') s = '0' // s                  ! gfortran writes F0.d without the 0
         if (s(1:min(2, len(s))) == '-.') s = '-0' // s(2:)
         return
      else if (abs(x) > 1.0e307_real64) then   ! reading a rounded value back might overflow
         write(buffer, '(es0.16)') x
      else
         do digits = 1, 16
            write(form, '(a, i0, a)') '(es0.', digits, ')'
            write(buffer, form) x
            read(buffer, *, iostat=status) y
            if (status == 0 .and. y == x) exit
         end do
      end if
      s = trim(adjustl(buffer))
   end function rstr

   function lstr(b) result(s)
      logical, intent(in) :: b
      character(len=:), allocatable :: s
      if (b) then
         s = '.true.'
      else
         s = '.false.'
      end if
   end function lstr

   !> s without leading and trailing blanks and tabs.
   function strip(s) result(t)
      character(len=*), intent(in) :: s
      character(len=:), allocatable :: t
      integer :: first, last
      first = 1
      last = len(s)
      do while (first <= last)
         if (s(first:first) /= ' ' .and. s(first:first) /= achar(9)) exit
         first = first + 1
      end do
      do while (last >= first)
         if (s(last:last) /= ' ' .and. s(last:last) /= achar(9)) exit
         last = last - 1
      end do
      t = s(first:last)
   end function strip

end module funit
