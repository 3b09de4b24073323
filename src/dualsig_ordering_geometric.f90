!> Fill-reducing ordering by geometric nested dissection (recursive coordinate bisection).
!>
!> Every unknown has a point in the plane (a mesh node, or a point on an edge for edge
!> unknowns).  A set of unknowns is split at the median of its points along the longer side
!> of its bounding box; the unknowns of the upper half that are coupled (in the matrix graph)
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
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_sparse_direct, only: ORDERING_AMD, ORDERING_GIVEN
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: geometric_nested_dissection, geometric_ordering, nd_min_unknowns

  !> Sets of at most this many unknowns are not split further.
  integer, parameter :: leaf_size = 64
  !> Smallest matrix ordered by nested dissection in `geometric_ordering`; smaller ones by AMD.
  !> Measured on P1 matrices of the unit square (make bench): the factor flops of nested
  !> dissection are 1.5x AMD's at 4e3 unknowns, 1.13x at 1.7e4, 0.87x at 6.6e4, 0.57x at 1e6.
  integer, parameter :: nd_min_unknowns = 30000

contains

  !> perm(k) = the unknown eliminated k-th (1-based), from the points xy(2, n) of the
  !> unknowns and the graph of `a` (its pattern; symmetric, both triangles stored).
  subroutine geometric_nested_dissection(xy, a, perm, st)
    real(dp), intent(in) :: xy(:,:)
    type(csr_t), intent(in) :: a
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: list(:), stamp(:)
    integer :: n, i, next_stamp
    n = a%n
    if (size(xy, 1) /= 2 .or. size(xy, 2) /= n) then
      call set_error(st, DS_ERR_INPUT, 'geometric_nested_dissection: xy must be (2, ' // itoa(n) // &
        '), got (' // itoa(size(xy, 1)) // ', ' // itoa(size(xy, 2)) // ')')
      allocate (perm(0))
      return
    end if
    allocate (perm(n), stamp(n), source=0)
    list = [(i, i=1, n)]
    next_stamp = 0
    call dissect(list, 1)

  contains

    !> Order the unknowns of `set` into perm(first : first + size(set) - 1).
    recursive subroutine dissect(set, first)
      integer, intent(inout) :: set(:)
      integer, intent(in) :: first
      integer :: m, half, axis, j, nsep, na, nb, s_low, s_high, side
      integer, allocatable :: part_a(:), part_b(:), sep(:)
      logical, allocatable :: touches(:)
      real(dp) :: lo(2), hi(2)
      m = size(set)
      if (m <= leaf_size) then
        perm(first:first + m - 1) = set
        return
      end if
      lo = [minval(xy(1, set)), minval(xy(2, set))]
      hi = [maxval(xy(1, set)), maxval(xy(2, set))]
      axis = merge(1, 2, hi(1) - lo(1) >= hi(2) - lo(2))
      half = m / 2
      call select_kth(set, axis, half)            ! set(1:half) <= set(half+1:) along axis
      s_low = next_stamp + 1
      s_high = next_stamp + 2
      next_stamp = next_stamp + 2
      stamp(set(1:half)) = s_low
      stamp(set(half + 1:m)) = s_high
      ! the unknowns of each half coupled to the other half: the smaller set is the separator
      allocate (touches(m))
      do j = 1, m
        touches(j) = coupled(set(j), merge(s_high, s_low, j <= half))
      end do
      side = merge(1, 2, count(touches(1:half)) <= count(touches(half + 1:m)))
      if (side == 1) then
        sep = pack(set(1:half), touches(1:half))
        part_a = pack(set(1:half), .not. touches(1:half))
        part_b = set(half + 1:m)
      else
        sep = pack(set(half + 1:m), touches(half + 1:m))
        part_a = set(1:half)
        part_b = pack(set(half + 1:m), .not. touches(half + 1:m))
      end if
      nsep = size(sep)
      na = size(part_a)
      nb = size(part_b)
      ! the separator last, the two parts before it
      perm(first + na + nb:first + m - 1) = sep
      if (na > 0) call dissect(part_a, first)
      if (nb > 0) call dissect(part_b, first + na)
    end subroutine dissect

    !> Unknown i has a neighbour (in the graph of a) stamped `other`.
    logical function coupled(i, other)
      integer, intent(in) :: i, other
      integer :: p
      coupled = .false.
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (stamp(a%col(p)) == other) then
          coupled = .true.
          return
        end if
      end do
    end function coupled

    !> Partial sort (quickselect): afterwards xy(axis, set(1:k)) <= xy(axis, set(k+1:)).
    subroutine select_kth(set, axis, k)
      integer, intent(inout) :: set(:)
      integer, intent(in) :: axis, k
      integer :: l, r, i, j, tmp
      real(dp) :: pivot
      l = 1
      r = size(set)
      do while (l < r)
        pivot = median_of_three(xy(axis, set(l)), xy(axis, set((l + r) / 2)), xy(axis, set(r)))
        i = l
        j = r
        do while (i <= j)
          do while (xy(axis, set(i)) < pivot)
            i = i + 1
          end do
          do while (xy(axis, set(j)) > pivot)
            j = j - 1
          end do
          if (i <= j) then
            tmp = set(i)
            set(i) = set(j)
            set(j) = tmp
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
  end subroutine geometric_nested_dissection

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

  pure real(dp) function median_of_three(a, b, c) result(m)
    real(dp), intent(in) :: a, b, c
    m = max(min(a, b), min(max(a, b), c))
  end function median_of_three
end module dualsig_ordering_geometric
