!> Error tables: one row per mesh level, written as aligned text and as CSV.
!>
!> A cell may be absent (not computed, not applicable); the CSV file writes it as `nan`
!> (the text as `-`) and keeps every column (a stable schema for scripts).  The aligned text shows only the
!> columns the caller marks as shown (table_show: e.g. no error columns without an exact
!> solution), and the text file drops as well the shown columns that stayed empty; so
!> neither has an always-`nan` column.  Absent cells are recorded in a mask, never as NaN
!> values, so that the floating-point traps of the checked build stay armed.  Columns are
!> integers or reals; the text gives reals 5 significant digits, except observed rates
!> (2 decimals), `eff` (6 decimals: 1.000001 is visible) and `energy_lo`, `energy_hi`
!> (7 significant digits).
module dualsig_io_table
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_io_files, only: text_file_t, text_open, text_put, text_close
  implicit none
  private

  public :: table_t, table_init, table_new_row, table_set, table_value, table_has, table_show, table_shown, &
            table_write_text, table_write_csv, table_write_latex, table_format_row, table_format_header, &
            observed_rate

  !> Least width of a text-table cell by kind (the column is two wider than this or its name):
  !> integers, observed rates (f0.2), eff (f0.6), energies (es, 7 digits), other reals (es, 5 digits)
  integer, parameter :: int_width = 6, rate_width = 5, eff_width = 9, energy_width = 13, real_width = 11
  !> eff is written with 6 decimals below this value, in scientific notation above
  real(dp), parameter :: eff_fixed_max = 1.0e4_dp
  !> Reals of the LaTeX table: 4 significant digits (mantissa d.ddd, exponent separate).
  character(len=*), parameter :: latex_real_fmt = '(es16.3e3)'

  type :: table_t
    integer :: ncol = 0
    integer :: nrow = 0
    character(len=16), allocatable :: name(:)     !! (ncol) column names
    logical, allocatable :: is_int(:)              !! (ncol) integer column
    logical, allocatable :: shown(:)               !! (ncol) column of the aligned text (table_show)
    real(dp), allocatable :: val(:,:)              !! (ncol, capacity)
    logical, allocatable :: present(:,:)           !! (ncol, capacity)
  end type table_t

contains

  !> A table with the given column names; names starting with '#' are integer columns
  !> (the '#' is removed).
  subroutine table_init(tab, names)
    type(table_t), intent(out) :: tab
    character(len=*), intent(in) :: names(:)
    integer :: k
    tab%ncol = size(names)
    allocate (tab%name(tab%ncol), tab%is_int(tab%ncol), tab%shown(tab%ncol))  ! small: one entry per column (a few dozen)
    tab%shown = .true.
    do k = 1, tab%ncol
      tab%is_int(k) = names(k)(1:1) == '#'
      if (tab%is_int(k)) then
        tab%name(k) = names(k)(2:)
      else
        tab%name(k) = names(k)
      end if
    end do
    allocate (tab%val(tab%ncol, 8), tab%present(tab%ncol, 8))  ! small: columns x 8 rows
    tab%present = .false.
  end subroutine table_init

  !> Append an empty row (all cells absent).
  subroutine table_new_row(tab)
    type(table_t), intent(inout) :: tab
    real(dp), allocatable :: v(:,:)
    logical, allocatable :: p(:,:)
    if (tab%nrow == size(tab%val, 2)) then
      allocate (v(tab%ncol, 2 * tab%nrow), p(tab%ncol, 2 * tab%nrow))  ! small: columns x rows (levels or adaptive steps)
      v(:, 1:tab%nrow) = tab%val
      p = .false.
      p(:, 1:tab%nrow) = tab%present
      call move_alloc(v, tab%val)
      call move_alloc(p, tab%present)
    end if
    tab%nrow = tab%nrow + 1
    tab%present(:, tab%nrow) = .false.
    tab%val(:, tab%nrow) = 0.0_dp
  end subroutine table_new_row

  !> Set the cell of column `name` in the last row.  Unknown names are ignored (returns
  !> silently: the column set is fixed by the caller at table_init).
  subroutine table_set(tab, name, value)
    type(table_t), intent(inout) :: tab
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: value
    integer :: k
    k = column(tab, name)
    if (k == 0 .or. tab%nrow == 0) return
    tab%val(k, tab%nrow) = value
    tab%present(k, tab%nrow) = .true.
  end subroutine table_set

  !> Show column `name` in the aligned text, or hide it (`shown` false; the CSV keeps it).
  !> Unknown names are ignored.
  subroutine table_show(tab, name, shown)
    type(table_t), intent(inout) :: tab
    character(len=*), intent(in) :: name
    logical, intent(in) :: shown
    integer :: k
    k = column(tab, name)
    if (k > 0) tab%shown(k) = shown
  end subroutine table_show

  !> True when column `name` is shown in the aligned text (table_show).
  pure logical function table_shown(tab, name)
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: name
    integer :: k
    k = column(tab, name)
    table_shown = .false.
    if (k > 0) table_shown = tab%shown(k)
  end function table_shown

  !> True when the cell (row, name) holds a value.
  pure logical function table_has(tab, row, name)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: row
    character(len=*), intent(in) :: name
    integer :: k
    k = column(tab, name)
    table_has = .false.
    if (k > 0 .and. row >= 1 .and. row <= tab%nrow) table_has = tab%present(k, row)
  end function table_has

  !> The value of cell (row, name); 0 when absent.
  pure real(dp) function table_value(tab, row, name)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: row
    character(len=*), intent(in) :: name
    integer :: k
    k = column(tab, name)
    table_value = 0.0_dp
    if (k > 0 .and. row >= 1 .and. row <= tab%nrow) table_value = tab%val(k, row)
  end function table_value

  !> Observed order log(e_prev / e) / log(h_prev / h); absent unless all four are positive.
  pure subroutine observed_rate(e_prev, e, h_prev, h, rate, ok)
    real(dp), intent(in) :: e_prev, e, h_prev, h
    real(dp), intent(out) :: rate
    logical, intent(out) :: ok
    ok = e_prev > 0.0_dp .and. e > 0.0_dp .and. h_prev > 0.0_dp .and. h > 0.0_dp &
         .and. h_prev /= h
    rate = 0.0_dp
    if (ok) rate = log(e_prev / e) / log(h_prev / h)
  end subroutine observed_rate

  !> The headings of the shown columns as one aligned text line.
  function table_format_header(tab) result(line)
    type(table_t), intent(in) :: tab
    character(len=:), allocatable :: line
    line = header_line(tab, text_columns(tab, .false.))
  end function table_format_header

  !> Row `row` of the shown columns as one aligned text line.
  function table_format_row(tab, row) result(line)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: row
    character(len=:), allocatable :: line
    line = row_line(tab, row, text_columns(tab, .false.))
  end function table_format_row

  !> The columns of the aligned text: the shown ones, without those with no value in any
  !> row when drop_empty.
  pure function text_columns(tab, drop_empty) result(cols)
    type(table_t), intent(in) :: tab
    logical, intent(in) :: drop_empty
    integer, allocatable :: cols(:)
    integer :: k
    allocate (cols(0))  ! small: column indices
    do k = 1, tab%ncol
      if (.not. tab%shown(k)) cycle
      if (drop_empty) then
        if (.not. any(tab%present(k, 1:tab%nrow))) cycle
      end if
      cols = [cols, k]
    end do
  end function text_columns

  !> Width of text column k: its name or its cells' least width, and two blanks.
  pure integer function text_width(tab, k)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: k
    integer :: w
    if (tab%is_int(k)) then
      w = int_width
    else if (index(tab%name(k), 'rate_') == 1) then
      w = rate_width
    else if (tab%name(k) == 'eff') then
      w = eff_width
    else if (tab%name(k) == 'energy_lo' .or. tab%name(k) == 'energy_hi') then
      w = energy_width
    else
      w = real_width
    end if
    text_width = max(len_trim(tab%name(k)), w) + 2
  end function text_width

  !> The headings of columns `cols`, right-aligned.
  pure function header_line(tab, cols) result(line)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: cols(:)
    character(len=:), allocatable :: line
    integer :: j, k
    line = ''
    do j = 1, size(cols)
      k = cols(j)
      line = line // repeat(' ', max(1, text_width(tab, k) - len_trim(tab%name(k)))) // trim(tab%name(k))
    end do
  end function header_line

  !> The cells of row `row` in columns `cols`, right-aligned.
  pure function row_line(tab, row, cols) result(line)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: row
    integer, intent(in) :: cols(:)
    character(len=:), allocatable :: line, c
    integer :: j
    line = ''
    do j = 1, size(cols)
      c = cell(tab, cols(j), row, .true.)
      line = line // repeat(' ', max(1, text_width(tab, cols(j)) - len(c))) // c
    end do
  end function row_line

  !> Write the aligned text table to temp_name(path): `header` lines first (each prefixed
  !> by '# '), then the column names and the rows.  The caller commits the file.
  subroutine table_write_text(tab, path, header, st)
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: path
    character(len=*), intent(in) :: header(:)
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    integer :: k, r
    integer, allocatable :: cols(:)
    character(len=:), allocatable :: heading
    call text_open(tf, path, st)
    if (st%code /= 0) return
    cols = text_columns(tab, .true.)
    heading = header_line(tab, cols)
    do k = 1, size(header)
      call text_put(tf, '# ' // trim(header(k)))
    end do
    call text_put(tf, '#' // heading(2:))
    do r = 1, tab%nrow
      call text_put(tf, row_line(tab, r, cols))
    end do
    call text_close(tf, st)
  end subroutine table_write_text

  !> Write the CSV table (header row, then one row per level, full precision) to
  !> temp_name(path).  The caller commits the file.
  subroutine table_write_csv(tab, path, st)
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    integer :: k, r
    character(len=:), allocatable :: line
    call text_open(tf, path, st)
    if (st%code /= 0) return
    line = trim(tab%name(1))
    do k = 2, tab%ncol
      line = line // ',' // trim(tab%name(k))
    end do
    call text_put(tf, line)
    do r = 1, tab%nrow
      line = cell(tab, 1, r, .false.)
      do k = 2, tab%ncol
        line = line // ',' // cell(tab, k, r, .false.)
      end do
      call text_put(tf, line)
    end do
    call text_close(tf, st)
  end subroutine table_write_csv

  !> Write the table as a LaTeX `booktabs` table (\toprule, \midrule, \bottomrule; the
  !> document needs \usepackage{booktabs}) to temp_name(path).  Column names and the
  !> caption have the LaTeX special characters escaped (level_s -> level\_s); integer
  !> columns are written as integers, reals in scientific notation as $d.ddd\times10^{e}$
  !> (plain $d.ddd$ for e = 0; no siunitx), absent cells as '--'.  `columns` selects and
  !> orders the columns (default: all); an unknown name is an input error.  The caller
  !> commits the file.
  subroutine table_write_latex(tab, path, caption, st, columns)
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: path
    character(len=*), intent(in) :: caption
    type(status_t), intent(out) :: st
    character(len=*), intent(in), optional :: columns(:)
    integer, allocatable :: cols(:)
    type(text_file_t) :: tf
    integer :: k, r
    character(len=:), allocatable :: line
    if (present(columns)) then
      allocate (cols(size(columns)))  ! small: column indices
      do k = 1, size(columns)
        cols(k) = column(tab, trim(columns(k)))
        if (cols(k) == 0) then
          call set_error(st, DS_ERR_INPUT, 'LaTeX table ' // trim(path) // ': no column "' // &
            trim(columns(k)) // '" in the table')
          return
        end if
      end do
    else
      cols = [(k, k=1, tab%ncol)]
    end if
    call text_open(tf, path, st)
    if (st%code /= 0) return
    call text_put(tf, '% dualsig error table; needs \usepackage{booktabs}')
    call text_put(tf, '\begin{table}[htbp]')
    call text_put(tf, '\centering')
    call text_put(tf, '\caption{' // latex_escape(trim(caption)) // '}')
    call text_put(tf, '\begin{tabular}{' // repeat('r', size(cols)) // '}')
    call text_put(tf, '\toprule')
    line = ''
    do k = 1, size(cols)
      if (k > 1) line = line // ' & '
      line = line // latex_escape(trim(tab%name(cols(k))))
    end do
    call text_put(tf, line // ' \\')
    call text_put(tf, '\midrule')
    do r = 1, tab%nrow
      line = ''
      do k = 1, size(cols)
        if (k > 1) line = line // ' & '
        line = line // latex_cell(tab, cols(k), r)
      end do
      call text_put(tf, line // ' \\')
    end do
    call text_put(tf, '\bottomrule')
    call text_put(tf, '\end{tabular}')
    call text_put(tf, '\end{table}')
    call text_close(tf, st)
  end subroutine table_write_latex

  ! ------------------------------------------------------------------ private
  pure integer function column(tab, name)
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: name
    integer :: k
    column = 0
    do k = 1, tab%ncol
      if (tab%name(k) == name) then
        column = k
        return
      end if
    end do
  end function column

  !> Cell text: short form for the aligned table (an absent cell '-'), full precision for
  !> CSV (an absent cell 'nan').
  pure function cell(tab, k, row, short) result(s)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: k, row
    logical, intent(in) :: short
    character(len=:), allocatable :: s
    character(len=32) :: buf
    if (.not. tab%present(k, row)) then
      s = trim(merge('-  ', 'nan', short))
      return
    end if
    if (tab%is_int(k)) then
      write (buf, '(i0)') nint(tab%val(k, row))
    else if (short .and. index(tab%name(k), 'rate_') == 1 .and. abs(tab%val(k, row)) < 1.0e3_dp) then
      write (buf, '(f8.2)') tab%val(k, row)
    else if (short .and. tab%name(k) == 'eff' .and. abs(tab%val(k, row)) < eff_fixed_max) then
      write (buf, '(f12.6)') tab%val(k, row)
    else if (short .and. (tab%name(k) == 'eff' .or. tab%name(k) == 'energy_lo' .or. tab%name(k) == 'energy_hi')) then
      write (buf, merge('(es14.6e3)', '(es14.6e2)', three_digit_exponent(tab%val(k, row)))) tab%val(k, row)
    else if (short) then
      write (buf, merge('(es12.4e3)', '(es12.4e2)', three_digit_exponent(tab%val(k, row)))) tab%val(k, row)
    else
      write (buf, '(es24.16e3)') tab%val(k, row)
    end if
    s = trim(adjustl(buf))
  end function cell

  !> x needs three exponent digits in scientific notation (|x| < 1e-99, or rounding to 1e100
  !> or more; not 0): written with two, its cell would be asterisks.
  pure logical function three_digit_exponent(x)
    real(dp), intent(in) :: x
    three_digit_exponent = x /= 0.0_dp .and. (abs(x) < 1.0e-99_dp .or. abs(x) >= 9.9999e99_dp)
  end function three_digit_exponent

  !> Cell text for LaTeX: integer, $d.ddd\times10^{e}$ (sign in the mantissa), or '--'.
  pure function latex_cell(tab, k, row) result(s)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: k, row
    character(len=:), allocatable :: s
    character(len=32) :: buf
    integer :: e, ios, k_exp
    if (.not. tab%present(k, row)) then
      s = '--'
      return
    end if
    if (tab%is_int(k)) then
      write (buf, '(i0)') nint(tab%val(k, row))
      s = trim(buf)
      return
    end if
    if (tab%val(k, row) == 0.0_dp) then
      s = '$0$'
      return
    end if
    write (buf, latex_real_fmt) tab%val(k, row)
    buf = adjustl(buf)
    e = index(buf, 'E')
    if (e == 0) then
      s = '$' // trim(buf) // '$'
      return
    end if
    read (buf(e + 1:), *, iostat=ios) k_exp
    s = '$' // buf(1:e - 1)
    if (ios == 0 .and. k_exp /= 0) then
      write (buf, '(i0)') k_exp
      s = s // '\times10^{' // trim(buf) // '}'
    end if
    s = s // '$'
  end function latex_cell

  !> `text` with the LaTeX special characters escaped for use in ordinary text.
  pure function latex_escape(text) result(s)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, len(text)
      select case (text(k:k))
      case ('_', '&', '%', '$', '#', '{', '}')
        s = s // '\' // text(k:k)
      case ('\')
        s = s // '\textbackslash{}'
      case ('~')
        s = s // '\textasciitilde{}'
      case ('^')
        s = s // '\textasciicircum{}'
      case default
        s = s // text(k:k)
      end select
    end do
  end function latex_escape
end module dualsig_io_table
