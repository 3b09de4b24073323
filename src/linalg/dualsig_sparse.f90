!> Compressed sparse row (CSR) matrices.
!>
!> Rows and columns are 1-based; the columns of every row are sorted increasingly and
!> contain the diagonal (FE patterns always do), whose position is kept in `diag`.
!> Symmetric matrices store both triangles.
module dualsig_sparse
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: csr_t, csr_pattern_from_edges, csr_pattern_from_cliques, csr_add, csr_add_block, &
            csr_get, csr_matvec, csr_is_symmetric, csr_nnz, csr_set_row_pattern, sort_small_ints, csr_move, &
            csr_quadratic_change, csr_gauss_seidel
  public :: rect_t, rect_from_triplets, rect_matvec, rect_matvec_t, sort_row_by_column, rect_move

  type :: csr_t
    integer :: n = 0                     !! number of rows = number of columns
    integer, allocatable :: rowptr(:)    !! (n+1) row k is val(rowptr(k):rowptr(k+1)-1)
    integer, allocatable :: col(:)       !! (nnz) column indices, sorted within each row
    integer, allocatable :: diag(:)      !! (n) position of the diagonal entry of each row
    real(dp), allocatable :: val(:)      !! (nnz) values
  end type csr_t

  !> Rectangular CSR matrix (m x n), e.g. constraint rows; columns sorted in each row.
  type :: rect_t
    integer :: m = 0                     !! rows
    integer :: n = 0                     !! columns
    integer, allocatable :: rowptr(:)    !! (m+1)
    integer, allocatable :: col(:)       !! (nnz)
    real(dp), allocatable :: val(:)      !! (nnz)
  end type rect_t

contains

  !> Number of stored entries.
  pure integer function csr_nnz(a)
    type(csr_t), intent(in) :: a
    csr_nnz = a%rowptr(a%n + 1) - 1
  end function csr_nnz

  !> Pattern of the graph "node i couples with itself and with its edge neighbours",
  !> values zero.  `edges(2, nedge)` lists each undirected edge once.  Linear time.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine csr_pattern_from_edges(n, edges, a, st)
    integer, intent(in) :: n
    integer, intent(in) :: edges(:,:)
    type(csr_t), intent(out) :: a
    type(status_t), intent(out) :: st
    integer, allocatable :: fill(:)
    integer :: e, i, j, k, p, tmp, ist
    a%n = n
    allocate (a%rowptr(n + 1), a%diag(n), fill(n), stat=ist)
    if (alloc_failed(ist, st, 'the rows of a sparse matrix', 3 * n, BYTES_INT)) return
    a%rowptr = 0
    a%rowptr(1) = 1
    fill = 1                               ! the diagonal
    do e = 1, size(edges, 2)
      fill(edges(1, e)) = fill(edges(1, e)) + 1
      fill(edges(2, e)) = fill(edges(2, e)) + 1
    end do
    do i = 1, n
      a%rowptr(i + 1) = a%rowptr(i) + fill(i)
    end do
    allocate (a%col(a%rowptr(n + 1) - 1), a%val(a%rowptr(n + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the entries of a sparse matrix', 3 * (a%rowptr(n + 1) - 1), BYTES_INT)) return
    a%val = 0.0_dp
    fill = 0
    do i = 1, n
      a%col(a%rowptr(i)) = i
      fill(i) = 1
    end do
    do e = 1, size(edges, 2)
      i = edges(1, e)
      j = edges(2, e)
      a%col(a%rowptr(i) + fill(i)) = j
      fill(i) = fill(i) + 1
      a%col(a%rowptr(j) + fill(j)) = i
      fill(j) = fill(j) + 1
    end do
    ! sort each (short) row by insertion sort and record the diagonal
    do i = 1, n
      do p = a%rowptr(i) + 1, a%rowptr(i + 1) - 1
        tmp = a%col(p)
        k = p - 1
        do while (k >= a%rowptr(i))
          if (a%col(k) <= tmp) exit
          a%col(k + 1) = a%col(k)
          k = k - 1
        end do
        a%col(k + 1) = tmp
      end do
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (a%col(p) == i) a%diag(i) = p
      end do
    end do
  end subroutine csr_pattern_from_edges

  !> Pattern in which all indices listed in one column of cliques(k, m) couple with each
  !> other (element matrices: each column holds the unknowns of one element); duplicates
  !> across cliques are merged, the diagonal is always present, values zero.  Built row by
  !> row from the cliques at each index (a marker per column merges the duplicates, so only
  !> a row's distinct columns are sorted, and no list with the duplicates is stored).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine csr_pattern_from_cliques(n, cliques, a, st)
    integer, intent(in) :: n
    integer, intent(in) :: cliques(:,:)
    type(csr_t), intent(out) :: a
    type(status_t), intent(out) :: st
    integer, allocatable :: at(:), inc(:), mark(:)
    integer :: c, r, i, j, pass, nk, ist, len, q
    nk = size(cliques, 1)
    ! the cliques at each index: inc(at(i):at(i+1)-1)
    allocate (at(n + 1), mark(n), a%rowptr(n + 1), a%diag(n), stat=ist)
    if (alloc_failed(ist, st, 'the rows of a sparse matrix', 4 * n + 2, BYTES_INT)) return
    at = 0
    do c = 1, size(cliques, 2)
      do r = 1, nk
        at(cliques(r, c) + 1) = at(cliques(r, c) + 1) + 1
      end do
    end do
    at(1) = 1
    do i = 1, n
      at(i + 1) = at(i + 1) + at(i)
    end do
    allocate (inc(at(n + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the element lists of a sparse matrix', at(n + 1) - 1, BYTES_INT)) return
    mark = at(1:n)
    do c = 1, size(cliques, 2)
      do r = 1, nk
        i = cliques(r, c)
        inc(mark(i)) = c
        mark(i) = mark(i) + 1
      end do
    end do
    ! pass 1 counts the distinct columns of every row, pass 2 stores and sorts them
    a%n = n
    a%rowptr(1) = 1
    do pass = 1, 2
      if (pass == 2) then
        allocate (a%col(a%rowptr(n + 1) - 1), a%val(a%rowptr(n + 1) - 1), stat=ist)
        if (alloc_failed(ist, st, 'the entries of a sparse matrix', 3 * (a%rowptr(n + 1) - 1), BYTES_INT)) return
        a%val = 0.0_dp
      end if
      mark = 0
      do i = 1, n
        len = 1
        mark(i) = i
        if (pass == 2) a%col(a%rowptr(i)) = i
        do q = at(i), at(i + 1) - 1
          do r = 1, nk
            j = cliques(r, inc(q))
            if (mark(j) == i) cycle
            mark(j) = i
            if (pass == 2) a%col(a%rowptr(i) + len) = j
            len = len + 1
          end do
        end do
        if (pass == 1) then
          a%rowptr(i + 1) = a%rowptr(i) + len
        else
          call sort_small_ints(a%col(a%rowptr(i):a%rowptr(i + 1) - 1))
          do q = a%rowptr(i), a%rowptr(i + 1) - 1
            if (a%col(q) == i) a%diag(i) = q
          end do
        end if
      end do
    end do
  end subroutine csr_pattern_from_cliques

  !> a(i, j) += v.  The entry must be in the pattern (returns ok = .false. otherwise).
  pure subroutine csr_add(a, i, j, v, ok)
    type(csr_t), intent(inout) :: a
    integer, intent(in) :: i, j
    real(dp), intent(in) :: v
    logical, intent(out) :: ok
    integer :: p
    ok = .false.
    do p = a%rowptr(i), a%rowptr(i + 1) - 1
      if (a%col(p) == j) then
        a%val(p) = a%val(p) + v
        ok = .true.
        return
      end if
    end do
  end subroutine csr_add

  !> a(idx, idx) += blk for a dense block on the index set idx (all entries in the pattern;
  !> entries outside it are skipped).
  pure subroutine csr_add_block(a, idx, blk)
    type(csr_t), intent(inout) :: a
    integer, intent(in) :: idx(:)
    real(dp), intent(in) :: blk(:,:)
    integer :: r, c, p
    do r = 1, size(idx)
      do c = 1, size(idx)
        do p = a%rowptr(idx(r)), a%rowptr(idx(r) + 1) - 1
          if (a%col(p) == idx(c)) then
            a%val(p) = a%val(p) + blk(r, c)
            exit
          end if
        end do
      end do
    end do
  end subroutine csr_add_block

  !> Rectangular m x n matrix from rows given as (row, col, value) triplets sorted by row
  !> (duplicates within a row are summed).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine rect_from_triplets(m, n, row, col, val, b, st)
    integer, intent(in) :: m, n
    integer, intent(in) :: row(:), col(:)
    real(dp), intent(in) :: val(:)
    type(rect_t), intent(out) :: b
    type(status_t), intent(out) :: st
    integer :: k, i, p, ist
    integer, allocatable :: fill(:)
    b%m = m
    b%n = n
    allocate (b%rowptr(m + 1), fill(m), b%col(size(row)), b%val(size(row)), stat=ist)
    if (alloc_failed(ist, st, 'a constraint matrix', 2 * m + 3 * size(row), BYTES_INT)) return
    b%rowptr = 0
    do k = 1, size(row)
      b%rowptr(row(k) + 1) = b%rowptr(row(k) + 1) + 1
    end do
    b%rowptr(1) = 1
    do i = 1, m
      b%rowptr(i + 1) = b%rowptr(i + 1) + b%rowptr(i)
    end do
    fill = 0
    do k = 1, size(row)
      p = b%rowptr(row(k)) + fill(row(k))
      b%col(p) = col(k)
      b%val(p) = val(k)
      fill(row(k)) = fill(row(k)) + 1
    end do
    do i = 1, m                             ! sort each short row by column
      call sort_row_by_column(b%col(b%rowptr(i):b%rowptr(i + 1) - 1), b%val(b%rowptr(i):b%rowptr(i + 1) - 1))
    end do
  end subroutine rect_from_triplets

  !> Sort the entries (col, val) of a short row by column (insertion sort, stable).
  pure subroutine sort_row_by_column(col, val)
    integer, intent(inout) :: col(:)
    real(dp), intent(inout) :: val(:)
    integer :: p, q, tmp_c
    real(dp) :: tmp_v
    do p = 2, size(col)
      tmp_c = col(p)
      tmp_v = val(p)
      q = p - 1
      do while (q >= 1)
        if (col(q) <= tmp_c) exit
        col(q + 1) = col(q)
        val(q + 1) = val(q)
        q = q - 1
      end do
      col(q + 1) = tmp_c
      val(q + 1) = tmp_v
    end do
  end subroutine sort_row_by_column

  !> w = B y  (w of size m).
  pure subroutine rect_matvec(b, y, w)
    type(rect_t), intent(in) :: b
    real(dp), intent(in) :: y(:)
    real(dp), intent(out) :: w(:)
    integer :: i, p
    do i = 1, b%m
      w(i) = 0.0_dp
      do p = b%rowptr(i), b%rowptr(i + 1) - 1
        w(i) = w(i) + b%val(p) * y(b%col(p))
      end do
    end do
  end subroutine rect_matvec

  !> y = B^T z  (y of size n).
  pure subroutine rect_matvec_t(b, z, y)
    type(rect_t), intent(in) :: b
    real(dp), intent(in) :: z(:)
    real(dp), intent(out) :: y(:)
    integer :: i, p
    y = 0.0_dp
    do i = 1, b%m
      do p = b%rowptr(i), b%rowptr(i + 1) - 1
        y(b%col(p)) = y(b%col(p)) + b%val(p) * z(i)
      end do
    end do
  end subroutine rect_matvec_t

  !> The value a(i, j) (zero when the entry is not stored).
  pure real(dp) function csr_get(a, i, j) result(v)
    type(csr_t), intent(in) :: a
    integer, intent(in) :: i, j
    integer :: p
    v = 0.0_dp
    do p = a%rowptr(i), a%rowptr(i + 1) - 1
      if (a%col(p) == j) then
        v = a%val(p)
        return
      end if
    end do
  end function csr_get

  !> One Gauss-Seidel sweep for A x = b, forward (rows 1..n) or backward, rows with a
  !> non-positive diagonal (no unknown left, e.g. after truncation) skipped.  decrease: the
  !> decrease of J(x) = x^T A x / 2 - b^T x the sweep made (A symmetric): updating x_i by
  !> s / a_ii, s = (b - A x)_i, lowers J by s^2 / (2 a_ii).
  pure subroutine csr_gauss_seidel(a, b, x, forward, decrease)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: b(:)
    real(dp), intent(inout) :: x(:)
    logical, intent(in) :: forward
    real(dp), intent(out), optional :: decrease
    integer :: i, p, i0, i1, di
    real(dp) :: s, d, dj
    if (forward) then
      i0 = 1
      i1 = a%n
      di = 1
    else
      i0 = a%n
      i1 = 1
      di = -1
    end if
    dj = 0.0_dp
    do i = i0, i1, di
      d = a%val(a%diag(i))
      if (d <= 0.0_dp) cycle
      s = b(i)
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        s = s - a%val(p) * x(a%col(p))
      end do
      x(i) = x(i) + s / d
      if (present(decrease)) dj = dj + s * s / d
    end do
    if (present(decrease)) decrease = 0.5_dp * dj
  end subroutine csr_gauss_seidel

  !> y = A x.
  pure subroutine csr_matvec(a, x, y)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: x(:)
    real(dp), intent(out) :: y(:)
    integer :: i, p
    real(dp) :: s
    do i = 1, a%n
      s = 0.0_dp
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        s = s + a%val(p) * x(a%col(p))
      end do
      y(i) = s
    end do
  end subroutine csr_matvec

  !> J(x_new) - J(x_old) for J(x) = 1/2 x^T A x - b^T x, A symmetric: with d = x_new - x_old,
  !> x_new^T A x_new - x_old^T A x_old = d^T A (x_new + x_old), so the change is the sum over
  !> the i with d_i /= 0 of d_i ((A (x_new + x_old))_i / 2 - b_i): only the rows of the
  !> unknowns that changed are read (a local update costs its support, not a product).
  pure real(dp) function csr_quadratic_change(a, b, x_old, x_new) result(dj)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: b(:), x_old(:), x_new(:)
    integer :: i, p
    real(dp) :: s
    dj = 0.0_dp
    do i = 1, a%n
      if (x_new(i) == x_old(i)) cycle
      s = 0.0_dp
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        s = s + a%val(p) * (x_new(a%col(p)) + x_old(a%col(p)))
      end do
      dj = dj + (x_new(i) - x_old(i)) * (0.5_dp * s - b(i))
    end do
  end function csr_quadratic_change

  !> True when |a(i,j) - a(j,i)| <= tol * sqrt(|a(i,i) a(j,j)|) for every stored entry:
  !> relative to the scale of the 2 x 2 principal block of i and j (|a(i,j)| is below it
  !> for an SPD matrix), so one large entry elsewhere (a penalty diagonal) does not hide an
  !> unsymmetric pair.  Where a diagonal entry is missing or zero, max|a| is the scale.
  pure logical function csr_is_symmetric(a, tol) result(sym)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: tol
    integer :: i, j, p
    real(dp) :: scale_max, scale
    scale_max = maxval(abs(a%val))
    sym = .true.
    do i = 1, a%n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        j = a%col(p)
        scale = scale_max
        if (.not. allocated(a%diag)) then
          continue
        else if (a%diag(i) > 0 .and. a%diag(j) > 0) then
          scale = sqrt(abs(a%val(a%diag(i)))) * sqrt(abs(a%val(a%diag(j))))
        end if
        if (.not. scale > 0.0_dp) scale = scale_max
        if (abs(a%val(p) - csr_get(a, j, i)) > tol * scale) then
          sym = .false.
          return
        end if
      end do
    end do
  end function csr_is_symmetric
  !> Row `row` of the pattern of a from the distinct columns `list` (any order): sorted into
  !> a%col(lo+1:lo+size(list)), a%diag(row) set when the row holds its diagonal.  a%col and
  !> a%diag are allocated by the caller (the Galerkin products' second pass).
  pure subroutine csr_set_row_pattern(a, row, lo, list)
    type(csr_t), intent(inout) :: a
    integer, intent(in) :: row, lo
    integer, intent(inout) :: list(:)
    integer :: k
    call sort_small_ints(list)
    a%col(lo + 1:lo + size(list)) = list
    do k = lo + 1, lo + size(list)
      if (a%col(k) == row) a%diag(row) = k
    end do
  end subroutine csr_set_row_pattern

  !> Sort a short integer list increasingly (insertion sort).
  pure subroutine sort_small_ints(v)
    integer, intent(inout) :: v(:)
    integer :: i, j, key
    do i = 2, size(v)
      key = v(i)
      j = i - 1
      do while (j >= 1)
        if (v(j) <= key) exit
        v(j + 1) = v(j)
        j = j - 1
      end do
      v(j + 1) = key
    end do
  end subroutine sort_small_ints

  !> b = a without copying the arrays (move_alloc): b's former contents are freed, b takes
  !> a's order and arrays (an array a lacks, b lacks too); a is left empty (csr_t()).
  pure subroutine csr_move(a, b)
    type(csr_t), intent(inout) :: a
    type(csr_t), intent(out) :: b
    b%n = a%n
    call move_alloc(a%rowptr, b%rowptr)
    call move_alloc(a%col, b%col)
    call move_alloc(a%diag, b%diag)
    call move_alloc(a%val, b%val)
    a = csr_t()
  end subroutine csr_move

  !> b = a without copying the arrays (move_alloc): b's former contents are freed, b takes
  !> a's sizes and arrays (an array a lacks, b lacks too); a is left empty (rect_t()).
  pure subroutine rect_move(a, b)
    type(rect_t), intent(inout) :: a
    type(rect_t), intent(out) :: b
    b%m = a%m
    b%n = a%n
    call move_alloc(a%rowptr, b%rowptr)
    call move_alloc(a%col, b%col)
    call move_alloc(a%val, b%val)
    a = rect_t()
  end subroutine rect_move
end module dualsig_sparse
