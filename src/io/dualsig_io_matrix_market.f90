!> Matrix Market export of a bound-constrained QP, for solving the same discrete problem
!> with other packages (bench/petsc_peers.py).
!>
!> Files written for a base name B (all 1-based, full precision):
!>   B_A.mtx     `coordinate real general`: the symmetric matrix, both triangles stored
!>   B_F.mtx     `array real general` (n x 1): the right-hand side F
!>   B_kind.mtx  `array integer general` (n x 1): 0 free, 1 lower bound, 2 fixed
!>   B_bnd.mtx   `array real general` (n x 1): the bound value (lower bound or fixed value)
!>   B_x.mtx     `array real general` (n x 1): dualsig's solution, for comparison
!> The QP is  min 1/2 x^T A x - F^T x  subject to the bounds.
module dualsig_io_matrix_market
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t
  use dualsig_status, only: status_t, set_error, DS_ERR_IO
  implicit none
  private

  public :: write_qp_matrix_market

contains

  !> Write the five files of the QP (A, F, kind, bnd) and the solution x under `base`.
  subroutine write_qp_matrix_market(base, a, f, kind, bnd, x, st)
    character(len=*), intent(in) :: base
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:), x(:)
    integer, intent(in) :: kind(:)
    type(status_t), intent(out) :: st
    integer :: u, ios, i, p
    character(len=256) :: msg
    open (newunit=u, file=base // '_A.mtx', status='replace', action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // base // '_A.mtx: ' // trim(msg))
      return
    end if
    write (u, '(a)') '%%MatrixMarket matrix coordinate real general'
    write (u, '(a)') '% dualsig QP matrix A (symmetric, both triangles stored)'
    write (u, '(i0,1x,i0,1x,i0)') a%n, a%n, a%rowptr(a%n + 1) - 1
    do i = 1, a%n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        write (u, '(i0,1x,i0,1x,es24.16e3)') i, a%col(p), a%val(p)
      end do
    end do
    close (u)
    call write_real_array(base // '_F.mtx', f, st)
    if (st%code /= 0) return
    call write_real_array(base // '_bnd.mtx', bnd, st)
    if (st%code /= 0) return
    call write_real_array(base // '_x.mtx', x, st)
    if (st%code /= 0) return
    open (newunit=u, file=base // '_kind.mtx', status='replace', action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // base // '_kind.mtx: ' // trim(msg))
      return
    end if
    write (u, '(a)') '%%MatrixMarket matrix array integer general'
    write (u, '(a)') '% 0 free, 1 x >= bnd, 2 x = bnd'
    write (u, '(i0,1x,i0)') size(kind), 1
    do i = 1, size(kind)
      write (u, '(i0)') kind(i)
    end do
    close (u)
  end subroutine write_qp_matrix_market

  !> A dense column vector in Matrix Market array format.
  subroutine write_real_array(path, v, st)
    character(len=*), intent(in) :: path
    real(dp), intent(in) :: v(:)
    type(status_t), intent(out) :: st
    integer :: u, ios, i
    character(len=256) :: msg
    open (newunit=u, file=path, status='replace', action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // path // ': ' // trim(msg))
      return
    end if
    write (u, '(a)') '%%MatrixMarket matrix array real general'
    write (u, '(i0,1x,i0)') size(v), 1
    do i = 1, size(v)
      write (u, '(es24.16e3)') v(i)
    end do
    close (u)
  end subroutine write_real_array
end module dualsig_io_matrix_market
