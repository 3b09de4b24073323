!> Solvers for A x = b with A symmetric positive definite and factorised once, behind one
!> abstract type, so that iterative methods (Uzawa, power iterations) work with either:
!> - `cholmod_spd_t`: a sparse CHOLMOD factor (dualsig_sparse_direct);
!> - `block_diag_spd_t`: a block-diagonal matrix of dense k x k blocks on consecutive
!>   unknowns (e.g. the 6 x 6 element matrices A_e of the equilibrium elements), each
!>   factorised by LAPACK dpotrf and solved by dpotrs.
module dualsig_spd_solver
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_solve, cholesky_free
  use dualsig_status, only: status_t, set_error, DS_ERR_LAPACK, DS_ERR_INPUT
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: spd_solver_t, cholmod_spd_t, block_diag_spd_t

  type, abstract :: spd_solver_t
  contains
    procedure(solve_iface), deferred :: solve
    procedure(size_iface), deferred :: n
  end type spd_solver_t

  abstract interface
    !> x = A^{-1} b.
    subroutine solve_iface(self, b, x, st)
      import :: spd_solver_t, dp, status_t
      class(spd_solver_t), intent(in) :: self
      real(dp), intent(in) :: b(:)
      real(dp), intent(out) :: x(:)
      type(status_t), intent(out) :: st
    end subroutine solve_iface
    !> Order of A.
    pure integer function size_iface(self)
      import :: spd_solver_t
      class(spd_solver_t), intent(in) :: self
    end function size_iface
  end interface

  !> A sparse matrix factorised by CHOLMOD.
  type, extends(spd_solver_t) :: cholmod_spd_t
    type(cholesky_t) :: chol
  contains
    procedure :: factor => cholmod_factor
    procedure :: solve => cholmod_solve
    procedure :: n => cholmod_n
    procedure :: free => cholmod_free
  end type cholmod_spd_t

  !> Dense k x k diagonal blocks, block j acting on unknowns (j-1) k + 1 .. j k.
  type, extends(spd_solver_t) :: block_diag_spd_t
    integer :: k = 0
    real(dp), allocatable :: l(:,:,:)   !! (k, k, nblock) Cholesky factors (lower triangle)
  contains
    procedure :: factor => block_factor
    procedure :: solve => block_solve
    procedure :: n => block_n
  end type block_diag_spd_t

contains

  !> Factorise the sparse SPD matrix a with CHOLMOD (ordering as in dualsig_sparse_direct).
  subroutine cholmod_factor(self, a, st, ordering, perm)
    class(cholmod_spd_t), intent(inout) :: self
    type(csr_t), intent(in) :: a
    type(status_t), intent(out) :: st
    integer, intent(in), optional :: ordering
    integer, intent(in), optional :: perm(:)     !! with ORDERING_GIVEN
    call cholesky_factor(a, self%chol, st, ordering, perm)
  end subroutine cholmod_factor

  subroutine cholmod_solve(self, b, x, st)
    class(cholmod_spd_t), intent(in) :: self
    real(dp), intent(in) :: b(:)
    real(dp), intent(out) :: x(:)
    type(status_t), intent(out) :: st
    call cholesky_solve(self%chol, b, x, st)
  end subroutine cholmod_solve

  pure integer function cholmod_n(self)
    class(cholmod_spd_t), intent(in) :: self
    cholmod_n = self%chol%n
  end function cholmod_n

  subroutine cholmod_free(self)
    class(cholmod_spd_t), intent(inout) :: self
    call cholesky_free(self%chol)
  end subroutine cholmod_free

  !> Factorise the blocks blocks(:,:,j) (each symmetric positive definite) by dpotrf.
  subroutine block_factor(self, blocks, st)
    class(block_diag_spd_t), intent(inout) :: self
    real(dp), intent(in) :: blocks(:,:,:)
    type(status_t), intent(out) :: st
    integer :: j, info
    external :: dpotrf
    self%k = size(blocks, 1)
    if (size(blocks, 2) /= self%k) then
      call set_error(st, DS_ERR_INPUT, 'block diagonal solver: blocks must be square')
      return
    end if
    self%l = blocks
    do j = 1, size(blocks, 3)
      call dpotrf('L', self%k, self%l(:, :, j), self%k, info)
      if (info /= 0) then
        call set_error(st, DS_ERR_LAPACK, 'block diagonal solver: dpotrf failed on block ' // itoa(j) // &
          ' (info = ' // itoa(info) // '): the block is not positive definite')
        return
      end if
    end do
  end subroutine block_factor

  subroutine block_solve(self, b, x, st)
    class(block_diag_spd_t), intent(in) :: self
    real(dp), intent(in) :: b(:)
    real(dp), intent(out) :: x(:)
    type(status_t), intent(out) :: st
    integer :: j, info, k
    external :: dpotrs
    k = self%k
    x = b
    do j = 1, size(self%l, 3)
      call dpotrs('L', k, 1, self%l(:, :, j), k, x((j - 1) * k + 1:j * k), k, info)
      if (info /= 0) then
        call set_error(st, DS_ERR_LAPACK, 'block diagonal solver: dpotrs failed (info = ' // itoa(info) // ')')
        return
      end if
    end do
  end subroutine block_solve

  pure integer function block_n(self)
    class(block_diag_spd_t), intent(in) :: self
    block_n = 0
    if (allocated(self%l)) block_n = self%k * size(self%l, 3)
  end function block_n
end module dualsig_spd_solver
