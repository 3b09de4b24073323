!> Shape classes of the triangles of a mesh: the triangles that are congruent with the same
!> vertex order, up to rounding.
!>
!> Every element matrix whose entries are integrals of products of gradients (the P1 and P2
!> stiffness matrices, the condensed Raviart-Thomas systems) depends on the triangle only
!> through the Gram matrix J^T J of its edges e1 = a_2 - a_1, e2 = a_3 - a_1 (the gradients'
!> inner products, the side lengths and det J > 0 follow from it), so triangles of one class
!> share them.  A uniform refinement makes no new shapes: the children of a red refinement
!> are the parent halved, the middle one halved and turned by pi with its vertices rotated,
!> so the last level of a uniform run from n0 triangles has at most 3 n0 classes, whatever
!> its size.  Triangles whose J^T J agree to shape_bits bits relative to their size
!> (shape_key) share a class; a user takes the matrices of the class's first triangle, which
!> changes them by a relative 2^-shape_bits at most (the coordinates of a fine mesh are
!> rounded at 2^-52 of the domain's size, so its children differ at that level anyway).
module dualsig_mesh_shapes
  use dualsig_kinds, only: dp, i8
  use dualsig_mesh, only: mesh_t
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  use dualsig_key_index, only: key_index_t, key_index_init, key_index_add
  implicit none
  private

  public :: shape_classes, shape_key, shape_bits

  !> Bits to which the edge Gram matrices of two triangles agree, relative to their size,
  !> when they share a shape class (shape_key).
  integer, parameter :: shape_bits = 38

contains

  !> The shape class cls(t) of every triangle t (module header), the first triangle of each
  !> class (rep) and their number, nshape.
  subroutine shape_classes(mesh, cls, rep, nshape, st)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable, intent(out) :: cls(:), rep(:)
    integer, intent(out) :: nshape
    type(status_t), intent(inout) :: st
    type(key_index_t) :: idx
    integer :: t, ist
    nshape = 0
    allocate (cls(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the shape classes of the triangles', mesh%ntri, BYTES_INT)) return
    call key_index_init(idx, 4, st)
    if (st%code /= 0) return
    do t = 1, mesh%ntri
      call key_index_add(idx, shape_key(mesh%xy(:, mesh%tri(:, t))), t, cls(t), st)
      if (st%code /= 0) return
    end do
    nshape = idx%n
    rep = idx%first(1:idx%n)
  end subroutine shape_classes

  !> The key of the shape class of the triangle xy (its vertices in the mesh's order): the
  !> entries of J^T J = [e1.e1, e1.e2, e2.e2] (e1 = a_2 - a_1, e2 = a_3 - a_1) rounded to
  !> shape_bits bits below their scale 2^e >= e1.e1 + e2.e2, and e.
  pure function shape_key(xy) result(key)
    real(dp), intent(in) :: xy(2, 3)
    integer(i8) :: key(4)
    real(dp) :: e1(2), e2(2), c(3)
    integer :: e
    e1 = xy(:, 2) - xy(:, 1)
    e2 = xy(:, 3) - xy(:, 1)
    c = [dot_product(e1, e1), dot_product(e1, e2), dot_product(e2, e2)]
    e = exponent(c(1) + c(3))
    key(1:3) = nint(scale(c, shape_bits - e), kind=i8)
    key(4) = int(e, i8)
  end function shape_key
end module dualsig_mesh_shapes
