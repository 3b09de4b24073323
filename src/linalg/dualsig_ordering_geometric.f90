!> Fill-reducing ordering by geometric nested dissection (recursive coordinate bisection).
!>
!> Every unknown has a point in the plane (a mesh node, or a point on an edge for edge
!> unknowns).  A set of unknowns is split at the median of its points along the longer side
!> of its bounding box, the points on the median line all on one side (so that a mesh line
!> becomes the separator); the unknowns of the upper half that are coupled (in the matrix graph)
!> to the lower half (or the other way round, whichever is smaller) form the separator,
!> which is eliminated last; the two halves without it
!> are ordered the same way, recursively, down to `leaf_size` unknowns.  On a mesh of a plane
!> domain this gives separators of O(sqrt(n)) unknowns and the O(n log n) fill of nested
!> dissection (Lipton, Rose and Tarjan), like METIS, at the cost of a few passes over the
!> unknowns per level (median selection, O(n) expected) instead of graph partitioning.
!> CHOLMOD post-orders the elimination tree of the given permutation; the numerical
!> factor is that of the same matrix, only the order of elimination differs.
module dualsig_ordering_geometric
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL, BYTES_LOGICAL
  use dualsig_sparse_direct, only: ORDERING_AMD, ORDERING_GIVEN, ORDERING_GEOMETRIC
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: geometric_nested_dissection, geometric_ordering, nd_min_unknowns, select_ordering

  !> Sets of at most this many unknowns are not split further.
  integer, parameter :: leaf_size = 64
  !> Smallest matrix ordered by nested dissection in `geometric_ordering`; smaller ones by AMD.
  !> Factor flops of nested dissection / AMD on the P1 matrices of the unit square
  !> (`bin/dualsig_bench large_p1` prints them per level): 0.83 at 1.7e4 unknowns, 0.62 at
  !> 6.6e4, 0.52 at 2.6e5, 0.41 at 1.05e6.
  integer, parameter :: nd_min_unknowns = 10000

contains

  !> perm(k) = the unknown eliminated k-th (1-based), from the points xy(2, n) of the
  !> unknowns and the graph of `a` (its pattern; symmetric, both triangles stored).
  subroutine geometric_nested_dissection(xy, a, perm, st)
    real(dp), intent(in) :: xy(:,:)
    type(csr_t), intent(in) :: a
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: list(:), stamp(:)
    real(dp), allocatable :: pts(:,:)
    real(dp) :: reach(2)
    integer :: n, i, p, next_stamp, ist
    n = a%n
    if (size(xy, 1) /= 2 .or. size(xy, 2) /= n) then
      call set_error(st, DS_ERR_INPUT, 'geometric_nested_dissection: xy must be (2, ' // itoa(n) // &
        '), got (' // itoa(size(xy, 1)) // ', ' // itoa(size(xy, 2)) // ')')
      allocate (perm(0))                  ! small: empty
      return
    end if
    ! reach(axis): the longest extent of a graph edge along the axis; an unknown farther than
    ! that from a split line has no neighbour on the other side
    reach = 0.0_dp
    do i = 1, n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        reach = max(reach, abs(xy(:, a%col(p)) - xy(:, i)))
      end do
    end do
    allocate (perm(n), stamp(n), list(n), pts(2, n), stat=ist)
    if (alloc_failed(ist, st, 'the nested dissection ordering', 3 * n + 4 * n, BYTES_INT)) return
    perm = 0
    stamp = 0
    do i = 1, n
      list(i) = i
    end do
    pts(:, :) = xy
    next_stamp = 0
    call dissect(list, pts, 1)

  contains

    !> Order the unknowns of `set` (with their points p, carried along so that every pass
    !> reads memory in order) into perm(first : first + size(set) - 1).
    recursive subroutine dissect(set, p, first)
      integer, intent(inout) :: set(:)
      real(dp), intent(inout) :: p(:,:)
      integer, intent(in) :: first
      integer :: m, half, axis, j, na, nb, nsep, ia, ib, is, s_low, s_high, side, ist
      integer, allocatable :: part_a(:), part_b(:), sep(:)
      real(dp), allocatable :: pa(:,:), pb(:,:)
      logical, allocatable :: touches(:)
      real(dp) :: lo(2), hi(2), split_lo, split_hi
      m = size(set)
      if (m <= leaf_size) then
        perm(first:first + m - 1) = set
        return
      end if
      lo = p(:, 1)
      hi = p(:, 1)
      do j = 2, m
        lo = min(lo, p(:, j))
        hi = max(hi, p(:, j))
      end do
      axis = merge(1, 2, hi(1) - lo(1) >= hi(2) - lo(2))
      half = m / 2
      call select_kth(p, axis, set, half)          ! p(axis, 1:half) <= p(axis, half+1:)
      ! points on the median line go to one side together (a mesh line is a natural
      ! separator; split at random it leaves a ragged one): the side that keeps the halves
      ! closer to equal
      call split_ties(p, axis, set, half)
      split_lo = maxval(p(axis, 1:half))
      split_hi = minval(p(axis, half + 1:m))
      s_low = next_stamp + 1
      s_high = next_stamp + 2
      next_stamp = next_stamp + 2
      stamp(set(1:half)) = s_low
      stamp(set(half + 1:m)) = s_high
      ! the unknowns of each half coupled to the other half (only those within reach of the
      ! split are examined): the smaller set is the separator
      allocate (touches(m), stat=ist)
      if (alloc_failed(ist, st, 'a nested dissection level', m, BYTES_LOGICAL)) return
      do j = 1, half
        touches(j) = split_hi - p(axis, j) <= reach(axis)
        if (touches(j)) touches(j) = coupled(set(j), s_high)
      end do
      do j = half + 1, m
        touches(j) = p(axis, j) - split_lo <= reach(axis)
        if (touches(j)) touches(j) = coupled(set(j), s_low)
      end do
      side = merge(1, 2, count(touches(1:half)) <= count(touches(half + 1:m)))
      ! the separator: the touching unknowns of the chosen side; the two parts: the rest
      if (side == 1) then
        nsep = count(touches(1:half))
        na = half - nsep
        nb = m - half
      else
        nsep = count(touches(half + 1:m))
        na = half
        nb = m - half - nsep
      end if
      allocate (part_a(na), part_b(nb), sep(nsep), pa(2, na), pb(2, nb), stat=ist)
      if (alloc_failed(ist, st, 'a nested dissection level', 5 * m, BYTES_REAL)) return
      ia = 0
      ib = 0
      is = 0
      do j = 1, m
        if (touches(j) .and. (j <= half .eqv. side == 1)) then
          is = is + 1
          sep(is) = set(j)
        else if (j <= half) then
          ia = ia + 1
          part_a(ia) = set(j)
          pa(:, ia) = p(:, j)
        else
          ib = ib + 1
          part_b(ib) = set(j)
          pb(:, ib) = p(:, j)
        end if
      end do
      deallocate (touches)
      ! the separator last, the two parts before it
      perm(first + na + nb:first + m - 1) = sep
      if (na > 0) call dissect(part_a, pa, first)
      if (.not. is_ok(st)) return
      deallocate (pa)
      if (nb > 0) call dissect(part_b, pb, first + na)
    end subroutine dissect

    !> Unknown i has a neighbour (in the graph of a) stamped `other`.
    logical function coupled(i, other)
      integer, intent(in) :: i, other
      integer :: q
      coupled = .false.
      do q = a%rowptr(i), a%rowptr(i + 1) - 1
        if (stamp(a%col(q)) == other) then
          coupled = .true.
          return
        end if
      end do
    end function coupled
  end subroutine geometric_nested_dissection

  !> After select_kth: move the points whose coordinate equals the median value v = p(axis, half)
  !> all to the lower part (<= v) or all to the upper part (< v below), whichever leaves the
  !> parts closer to m/2; half becomes the size of the lower part (unchanged when the
  !> choice would empty a part).
  pure subroutine split_ties(p, axis, set, half)
    real(dp), intent(inout) :: p(:,:)
    integer, intent(in) :: axis
    integer, intent(inout) :: set(:)
    integer, intent(inout) :: half
    real(dp) :: v
    integer :: m, below, equal, nlow
    logical :: include_equal
    m = size(set)
    v = p(axis, half)
    below = count(p(axis, :) < v)
    equal = count(p(axis, :) == v)
    include_equal = abs(below + equal - m / 2) < abs(below - m / 2)
    nlow = merge(below + equal, below, include_equal)
    if (nlow == 0 .or. nlow == m) return
    call partition_at(p, axis, set, v, include_equal)
    half = nlow
  end subroutine split_ties

  !> Two-pointer partition: the points with coordinate < v (with_equal: <= v) first.
  pure subroutine partition_at(p, axis, set, v, with_equal)
    real(dp), intent(inout) :: p(:,:)
    integer, intent(in) :: axis
    integer, intent(inout) :: set(:)
    real(dp), intent(in) :: v
    logical, intent(in) :: with_equal
    integer :: i, j, m, itmp
    real(dp) :: tmp(2)
    m = size(set)
    i = 1
    j = m
    do
      do while (i <= m)
        if (.not. (p(axis, i) < v .or. (with_equal .and. p(axis, i) == v))) exit
        i = i + 1
      end do
      do while (j >= 1)
        if (p(axis, j) < v .or. (with_equal .and. p(axis, j) == v)) exit
        j = j - 1
      end do
      if (i >= j) exit
      tmp = p(:, i)
      p(:, i) = p(:, j)
      p(:, j) = tmp
      itmp = set(i)
      set(i) = set(j)
      set(j) = itmp
    end do
  end subroutine partition_at

  !> Partial sort (quickselect) of the points p along `axis`, with set permuted alike:
  !> afterwards p(axis, 1:k) <= p(axis, k+1:).
  pure subroutine select_kth(p, axis, set, k)
    real(dp), intent(inout) :: p(:,:)
    integer, intent(in) :: axis
    integer, intent(inout) :: set(:)
    integer, intent(in) :: k
    integer :: l, r, i, j, itmp
    real(dp) :: pivot, tmp(2)
    l = 1
    r = size(set)
    do while (l < r)
      pivot = median_of_three(p(axis, l), p(axis, (l + r) / 2), p(axis, r))
      i = l
      j = r
      do while (i <= j)
        do while (p(axis, i) < pivot)
          i = i + 1
        end do
        do while (p(axis, j) > pivot)
          j = j - 1
        end do
        if (i <= j) then
          tmp = p(:, i)
          p(:, i) = p(:, j)
          p(:, j) = tmp
          itmp = set(i)
          set(i) = set(j)
          set(j) = itmp
          i = i + 1
          j = j - 1
        end if
      end do
      if (k <= j) then
        r = j
      else if (k >= i) then
        l = i
      else
        exit
      end if
    end do
  end subroutine select_kth

  !> The ordering for CHOLMOD chosen by size (the cheaper factorisation, see nd_min_unknowns):
  !> ord = ORDERING_GIVEN with the geometric nested dissection in perm, or ORDERING_AMD
  !> (perm not allocated).
  subroutine geometric_ordering(xy, a, ord, perm, st)
    real(dp), intent(in) :: xy(:,:)
    type(csr_t), intent(in) :: a
    integer, intent(out) :: ord
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    if (a%n < nd_min_unknowns) then
      ord = ORDERING_AMD
      return
    end if
    call geometric_nested_dissection(xy, a, perm, st)
    ord = ORDERING_GIVEN
  end subroutine geometric_ordering

  !> The ordering CHOLMOD is given for the requested one, the single place where it is
  !> chosen: ORDERING_GEOMETRIC becomes geometric_ordering's choice (nested dissection of the
  !> points xy(2, n) of the unknowns, or AMD for small matrices); every other ordering is
  !> passed on unchanged (perm is then not allocated).
  subroutine select_ordering(requested, xy, a, ord, perm, st)
    integer, intent(in) :: requested
    real(dp), intent(in) :: xy(:,:)
    type(csr_t), intent(in) :: a
    integer, intent(out) :: ord
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    ord = requested
    if (requested == ORDERING_GEOMETRIC) call geometric_ordering(xy, a, ord, perm, st)
  end subroutine select_ordering

  pure real(dp) function median_of_three(a, b, c) result(m)
    real(dp), intent(in) :: a, b, c
    m = max(min(a, b), min(max(a, b), c))
  end function median_of_three
end module dualsig_ordering_geometric
