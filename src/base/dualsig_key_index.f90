!> Classes of integer keys: an open-addressing hash table that numbers the distinct keys
!> (fixed length, 64-bit entries) 1, 2, ... in the order they are first met and keeps the
!> first item of each class.  Used to share the work of equal objects (the shape classes of
!> triangles and the types of vertex patches of dualsig_dual_hdiv_smoother).
!>
!>     call key_index_init(idx, 4, st)
!>     call key_index_add(idx, key, item, c, st)    ! c: the class of key, new or met before
!>     c = key_index_find(idx, key)                 ! 0 when not met
!>
!> The table is at most half full; its arrays double when needed.
module dualsig_key_index
  use dualsig_kinds, only: i8
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  implicit none
  private

  public :: key_index_t, key_index_init, key_index_add, key_index_find

  !> Classes made room for at the start.
  integer, parameter :: first_capacity = 64

  !> The classes met so far: their keys, first items, and the hash table (slot(0:size-1):
  !> class, 0 empty).
  type :: key_index_t
    integer :: n = 0                       !! classes
    integer :: length = 0                  !! entries of a key
    integer(i8), allocatable :: key(:,:)   !! (length, capacity)
    integer, allocatable :: first(:)       !! (capacity) the first item of each class
    integer, allocatable :: slot(:)
  end type key_index_t

contains

  !> An empty index of keys of `length` entries.  Out of memory: DS_ERR_MEMORY in st.
  subroutine key_index_init(idx, length, st)
    type(key_index_t), intent(out) :: idx
    integer, intent(in) :: length
    type(status_t), intent(inout) :: st
    integer :: ist
    idx%length = length
    allocate (idx%key(length, first_capacity), idx%first(first_capacity), idx%slot(0:2 * first_capacity - 1), &
              stat=ist)
    if (alloc_failed(ist, st, 'a table of classes', (2 * length + 3) * first_capacity, BYTES_INT)) return
    idx%slot = 0
  end subroutine key_index_init

  !> The class c of key: that of an equal key met before, else a new class with first item
  !> `item`.  Out of memory: DS_ERR_MEMORY in st (c = 0).
  subroutine key_index_add(idx, key, item, c, st)
    type(key_index_t), intent(inout) :: idx
    integer(i8), intent(in) :: key(:)
    integer, intent(in) :: item
    integer, intent(out) :: c
    type(status_t), intent(inout) :: st
    integer :: s
    c = 0
    if (idx%n == size(idx%first)) then
      call key_index_grow(idx, st)
      if (st%code /= 0) return
    end if
    call probe(idx, key, c, s)
    if (c /= 0) return
    idx%n = idx%n + 1
    c = idx%n
    idx%key(:, c) = key
    idx%first(c) = item
    idx%slot(s) = c
  end subroutine key_index_add

  !> The class of key, 0 when no equal key was added.
  pure integer function key_index_find(idx, key) result(c)
    type(key_index_t), intent(in) :: idx
    integer(i8), intent(in) :: key(:)
    integer :: s
    call probe(idx, key, c, s)
  end function key_index_find

  !> Linear probing from key's hash: the class c of an equal key, or c = 0 and the empty
  !> slot s where it would go.
  pure subroutine probe(idx, key, c, s)
    type(key_index_t), intent(in) :: idx
    integer(i8), intent(in) :: key(:)
    integer, intent(out) :: c, s
    integer :: mask
    mask = size(idx%slot) - 1
    s = int(iand(key_hash(key), int(mask, i8)))
    do
      c = idx%slot(s)
      if (c == 0) return
      if (all(idx%key(:, c) == key)) return
      s = iand(s + 1, mask)
    end do
  end subroutine probe

  !> A hash of a key: each entry folded in after rotating what came before, then the high
  !> bits folded onto the low ones (the table takes the low bits).
  pure integer(i8) function key_hash(key) result(h)
    integer(i8), intent(in) :: key(:)
    integer :: i
    h = 0_i8
    do i = 1, size(key)
      h = ieor(ishftc(h, 23), key(i))
    end do
    h = ieor(h, ishft(h, -29))
    h = ieor(h, ishft(h, -13))
  end function key_hash

  !> The arrays of idx at twice their capacity, the classes hashed again.
  subroutine key_index_grow(idx, st)
    type(key_index_t), intent(inout) :: idx
    type(status_t), intent(inout) :: st
    integer(i8), allocatable :: key(:,:)
    integer, allocatable :: first(:)
    integer :: cap, c, k, mask, ist
    cap = 2 * size(idx%first)
    allocate (key(idx%length, cap), first(cap), stat=ist)
    if (alloc_failed(ist, st, 'a table of classes', (2 * idx%length + 1) * cap, BYTES_INT)) return
    key(:, 1:idx%n) = idx%key(:, 1:idx%n)
    first(1:idx%n) = idx%first(1:idx%n)
    call move_alloc(key, idx%key)
    call move_alloc(first, idx%first)
    deallocate (idx%slot)
    allocate (idx%slot(0:2 * cap - 1), source=0, stat=ist)
    if (alloc_failed(ist, st, 'a table of classes', 2 * cap, BYTES_INT)) return
    mask = 2 * cap - 1
    do c = 1, idx%n
      k = int(iand(key_hash(idx%key(:, c)), int(mask, i8)))
      do while (idx%slot(k) /= 0)
        k = iand(k + 1, mask)
      end do
      idx%slot(k) = c
    end do
  end subroutine key_index_grow
end module dualsig_key_index
