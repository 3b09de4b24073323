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
  use dualsig_status, only: status_t
  use dualsig_io_files, only: text_file_t, text_open, text_put, text_close, file_commit_all, file_delete, temp_name
  implicit none
  private

  public :: write_qp_matrix_market

contains

  !> Write the five files of the QP (A, F, kind, bnd) and the solution x under `base`:
  !> each under its temporary name with every write checked, then committed as a set
  !> (file_commit_all); on a failure none of them is replaced and no temporary file is left.
  subroutine write_qp_matrix_market(base, a, f, kind, bnd, x, st)
    character(len=*), intent(in) :: base
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:), x(:)
    integer, intent(in) :: kind(:)
    type(status_t), intent(out) :: st
    character(len=len(base) + len('_kind.mtx')) :: paths(5)
    type(text_file_t) :: tf
    character(len=80) :: buf
    integer :: i, p, k
    paths(1) = base // '_A.mtx'
    paths(2) = base // '_F.mtx'
    paths(3) = base // '_bnd.mtx'
    paths(4) = base // '_x.mtx'
    paths(5) = base // '_kind.mtx'
    call text_open(tf, paths(1), st)
    if (st%code /= 0) return
    call text_put(tf, '%%MatrixMarket matrix coordinate real general')
    call text_put(tf, '% dualsig QP matrix A (symmetric, both triangles stored)')
    write (buf, '(i0,1x,i0,1x,i0)') a%n, a%n, a%rowptr(a%n + 1) - 1
    call text_put(tf, trim(buf))
    do i = 1, a%n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        write (buf, '(i0,1x,i0,1x,es24.16e3)') i, a%col(p), a%val(p)
        call text_put(tf, trim(buf))
      end do
    end do
    call text_close(tf, st)
    if (st%code == 0) call write_real_array(paths(2), f, st)
    if (st%code == 0) call write_real_array(paths(3), bnd, st)
    if (st%code == 0) call write_real_array(paths(4), x, st)
    if (st%code == 0) call text_open(tf, paths(5), st)
    if (st%code == 0) then
      call text_put(tf, '%%MatrixMarket matrix array integer general')
      call text_put(tf, '% 0 free, 1 x >= bnd, 2 x = bnd')
      write (buf, '(i0,1x,i0)') size(kind), 1
      call text_put(tf, trim(buf))
      do i = 1, size(kind)
        write (buf, '(i0)') kind(i)
        call text_put(tf, trim(buf))
      end do
      call text_close(tf, st)
    end if
    if (st%code == 0) then
      call file_commit_all(paths, st)
    else
      do k = 1, size(paths)
        call file_delete(temp_name(paths(k)))
      end do
    end if
  end subroutine write_qp_matrix_market

  !> A dense column vector in Matrix Market array format, to temp_name(path).
  subroutine write_real_array(path, v, st)
    character(len=*), intent(in) :: path
    real(dp), intent(in) :: v(:)
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    character(len=40) :: buf
    integer :: i
    call text_open(tf, path, st)
    if (st%code /= 0) return
    call text_put(tf, '%%MatrixMarket matrix array real general')
    write (buf, '(i0,1x,i0)') size(v), 1
    call text_put(tf, trim(buf))
    do i = 1, size(v)
      write (buf, '(es24.16e3)') v(i)
      call text_put(tf, trim(buf))
    end do
    call text_close(tf, st)
  end subroutine write_real_array
end module dualsig_io_matrix_market
