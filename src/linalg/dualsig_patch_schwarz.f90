!> Additive Schwarz preconditioner with small dense blocks ("patches") and the
!> preconditioned conjugate gradient method on a subset of the unknowns.
!>
!> A patch is a list of unknowns; the preconditioner is
!>     M^{-1} r = sum_P R_P^T (R_P A R_P^T)^{-1} R_P r,
!> each patch block factorised once by a dense Cholesky factorisation (packed lower
!> triangle).  With the vertex patches of Arnold, Falk and Winther (all unknowns of the
!> edges at a vertex) it is the smoother of their H(div) multigrid, robust on the
!> discretely divergence-free components where point (Jacobi) blocks are not.
!>
!> A hierarchy of nested spaces (mg_hierarchy_t: level matrices A_l, prolongations P_l from
!> level l-1 to l, the patches of every level, A_1 factorised by CHOLMOD) gives the
!> symmetric V-cycle used as preconditioner: damped patch Schwarz before and after the
!> coarse correction P_l (V-cycle of level l-1) P_l^T.  Every level has a set of `held`
!> unknowns (zero in its correction space: the rows and columns of A_l restricted away;
!> its patches must not contain the `bounded` ones, which are smoothed by point blocks
!> when not held); mg_hold sets them from the finest level's free unknowns.  A coarse space must hold
!> what the finer one holds after prolongation (e.g. a zero normal trace on a boundary),
!> or the truncated coarse corrections do not match the coarse matrices.
!>
!> pcg_quadratic minimises J(x) = 1/2 x^T A x - b^T x (A the finest level's matrix) over
!> the unknowns marked free (the others keep their values; the preconditioner is truncated
!> to the free unknowns) and stops when the last decrease of J is at most `rel` times
!> J(x) - j_floor, j_floor a lower bound of J supplied by the caller (the decrease per step
!> relative to what is left to gain at most: a computable criterion).
module dualsig_patch_schwarz
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, csr_matvec, rect_t, rect_matvec, rect_matvec_t
  use dualsig_spd_solver, only: cholmod_spd_t
  use dualsig_status, only: status_t, set_error, DS_ERR_NUMERIC, DS_ERR_MEMORY
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: patch_schwarz_t, patch_schwarz_setup, patch_schwarz_apply, pcg_quadratic, pcg_result_t
  public :: mg_hierarchy_t, mg_add_level, mg_free, mg_hold, mg_max_levels

  !> Most levels of a hierarchy.
  integer, parameter :: mg_max_levels = 24
  !> Damping of the additive patch smoother (each unknown lies in two vertex patches).
  real(dp), parameter :: smoother_damping = 0.3_dp

  !> The patches and the Cholesky factors of their blocks.
  type :: patch_schwarz_t
    integer :: npatch = 0
    integer :: max_size = 0              !! largest patch
    integer, allocatable :: ptr(:)       !! (npatch+1) patch p is idx(ptr(p):ptr(p+1)-1)
    integer, allocatable :: idx(:)       !! unknowns of the patches
    integer(i8), allocatable :: foff(:) !! (npatch+1) factor of p is fac(foff(p):foff(p+1)-1)
    real(dp), allocatable :: fac(:)      !! packed lower Cholesky factors, column by column
  end type patch_schwarz_t

  !> One level of a hierarchy.
  type :: mg_level_t
    type(csr_t) :: a                     !! the level's matrix
    type(rect_t) :: p                    !! prolongation from level l-1 (levels >= 2)
    type(patch_schwarz_t) :: ps          !! the smoother's patches (levels >= 2)
    logical, allocatable :: bounded(:)   !! unknowns that may be held (not in the patches)
    logical, allocatable :: held(:)      !! unknowns held at zero (mg_hold)
  end type mg_level_t

  !> Nested levels, coarsest first.
  type :: mg_hierarchy_t
    integer :: nlevel = 0
    type(mg_level_t) :: lev(mg_max_levels)
    type(cholmod_spd_t) :: coarse        !! A_1 factorised, held rows and columns those of I
    logical :: factored = .false.
  end type mg_hierarchy_t

  !> What pcg_quadratic did.
  type :: pcg_result_t
    integer :: iterations = 0
    logical :: converged = .false.       !! the stopping criterion was met
    real(dp) :: last_decrease = 0.0_dp   !! J decrease of the last step
    real(dp) :: j_value = 0.0_dp         !! J at the returned x
  end type pcg_result_t

contains

  !> Append a finer level: its matrix a and (from the second level on) the prolongation p
  !> from the previous level (moved into the hierarchy), its patches ptr/idx factorised;
  !> the first level's matrix is factorised by CHOLMOD.
  subroutine mg_add_level(h, a, p, ptr, idx, bounded, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(inout) :: a
    type(rect_t), intent(inout) :: p
    integer, intent(in) :: ptr(:), idx(:)
    logical, intent(in) :: bounded(:)
    type(status_t), intent(out) :: st
    integer :: l
    if (h%nlevel == mg_max_levels) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: more than ' // itoa(mg_max_levels) // ' levels')
      return
    end if
    l = h%nlevel + 1
    st%code = 0
    if (l > 1) then
      call patch_schwarz_setup(a, ptr, idx, h%lev(l)%ps, st)
      if (st%code /= 0) return
      h%lev(l)%p = p
      p = rect_t()
    end if
    h%lev(l)%a = a
    h%lev(l)%bounded = bounded
    h%lev(l)%held = bounded
    a = csr_t()
    h%nlevel = l
  end subroutine mg_add_level

  !> Hold the unknowns of the finest level that are not free, and on every coarser level
  !> the bounded unknowns whose prolongation reaches a held finer one (so that coarse
  !> corrections never touch a held unknown); the coarsest matrix is factorised again with
  !> the rows and columns of its held unknowns those of the identity.
  subroutine mg_hold(h, free, st)
    type(mg_hierarchy_t), intent(inout) :: h
    logical, intent(in) :: free(:)
    type(status_t), intent(out) :: st
    type(csr_t) :: a_held
    integer :: l, i, q
    h%lev(h%nlevel)%held = .not. free
    do l = h%nlevel, 2, -1
      associate (lc => h%lev(l - 1), pl => h%lev(l)%p)
        lc%held = .false.
        do i = 1, pl%m
          if (.not. h%lev(l)%held(i)) cycle
          do q = pl%rowptr(i), pl%rowptr(i + 1) - 1
            if (abs(pl%val(q)) > 0.0_dp .and. lc%bounded(pl%col(q))) lc%held(pl%col(q)) = .true.
          end do
        end do
      end associate
    end do
    associate (a => h%lev(1)%a, held => h%lev(1)%held)
      a_held = a
      do i = 1, a%n
        do q = a%rowptr(i), a%rowptr(i + 1) - 1
          if (held(i) .or. held(a%col(q))) a_held%val(q) = merge(1.0_dp, 0.0_dp, a%col(q) == i)
        end do
      end do
    end associate
    if (h%factored) call h%coarse%free()
    call h%coarse%factor(a_held, st)
    h%factored = st%code == 0
  end subroutine mg_hold

  !> Release a hierarchy.
  subroutine mg_free(h)
    type(mg_hierarchy_t), intent(inout) :: h
    if (h%factored) call h%coarse%free()
    h%factored = .false.
    h%nlevel = 0
    h%lev = mg_level_t()
  end subroutine mg_free

  !> z = B r, B the symmetric V-cycle of level l (truncated to `free` at level top).
  !> Out of memory: DS_ERR_MEMORY in st.
  recursive subroutine vcycle(h, l, top, r, z, st)
    type(mg_hierarchy_t), intent(in) :: h
    integer, intent(in) :: l, top
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: z(:)
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: res(:), rc(:), zc(:), dz(:), rm(:)
    logical, allocatable :: act(:)
    type(status_t) :: st_coarse
    integer :: ist
    if (l == 1) then
      res = merge(r, 0.0_dp, .not. h%lev(1)%held)
      call h%coarse%solve(res, z, st_coarse)
      return
    end if
    act = .not. h%lev(l)%held
    rm = merge(r, 0.0_dp, act)
    associate (lv => h%lev(l))
      allocate (res(lv%a%n), dz(lv%a%n), rc(lv%p%n), zc(lv%p%n), stat=ist)
      if (alloc_failed(ist, st, 'a level of the V-cycle', 2 * (lv%a%n + lv%p%n), BYTES_REAL)) return
      call smooth(lv, rm, z)
      z = smoother_damping * z
      where (.not. act) z = 0.0_dp
      call csr_matvec(lv%a, z, res)
      res = rm - res
      where (.not. act) res = 0.0_dp
      call rect_matvec_t(lv%p, res, rc)
      call vcycle(h, l - 1, top, rc, zc, st)
      if (st%code /= 0) return
      call rect_matvec(lv%p, zc, dz)
      where (.not. act) dz = 0.0_dp
      z = z + dz
      call csr_matvec(lv%a, z, res)
      res = rm - res
      where (.not. act) res = 0.0_dp
      call smooth(lv, res, dz)
      z = z + smoother_damping * dz
      where (.not. act) z = 0.0_dp
    end associate
  end subroutine vcycle

  !> z = M^{-1} r: the patches of level lv, and point (Jacobi) blocks for its bounded
  !> unknowns that are not held.
  pure subroutine smooth(lv, r, z)
    type(mg_level_t), intent(in) :: lv
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: z(:)
    integer :: i
    call patch_schwarz_apply(lv%ps, r, z)
    do i = 1, size(z)
      if (lv%bounded(i) .and. .not. lv%held(i)) z(i) = z(i) + r(i) / lv%a%val(lv%a%diag(i))
    end do
  end subroutine smooth

  !> Factorise the blocks of the patches ptr/idx of the SPD matrix a (columns sorted).
  !> Empty patches are allowed.  DS_ERR_NUMERIC when a block is not positive definite.
  subroutine patch_schwarz_setup(a, ptr, idx, ps, st)
    type(csr_t), intent(in) :: a
    integer, intent(in) :: ptr(:), idx(:)
    type(patch_schwarz_t), intent(out) :: ps
    type(status_t), intent(out) :: st
    integer, allocatable :: pos(:)
    real(dp), allocatable :: blk(:,:)
    integer :: p, m, i, k, q, ierr
    integer(i8) :: off
    ps%npatch = size(ptr) - 1
    ps%ptr = ptr
    ps%idx = idx
    allocate (ps%foff(ps%npatch + 1), stat=ierr)
    if (ierr == 0) allocate (pos(a%n), source=0, stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_MEMORY, 'patch Schwarz: out of memory (' // itoa(a%n) // ' unknowns)')
      return
    end if
    ps%foff(1) = 1
    do p = 1, ps%npatch
      m = ptr(p + 1) - ptr(p)
      ps%max_size = max(ps%max_size, m)
      ps%foff(p + 1) = ps%foff(p) + int(m, i8) * (m + 1) / 2
    end do
    allocate (ps%fac(ps%foff(ps%npatch + 1) - 1), stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_MEMORY, 'patch Schwarz: out of memory for the patch factors')
      return
    end if
    do p = 1, ps%npatch
      m = ptr(p + 1) - ptr(p)
      if (m == 0) cycle
      if (allocated(blk)) then
        if (size(blk, 1) < m) deallocate (blk)
      end if
      if (.not. allocated(blk)) allocate (blk(m, m))   ! small: one vertex patch
      do k = 1, m
        pos(idx(ptr(p) + k - 1)) = k
      end do
      blk(1:m, 1:m) = 0.0_dp
      do k = 1, m
        i = idx(ptr(p) + k - 1)
        do q = a%rowptr(i), a%rowptr(i + 1) - 1
          if (pos(a%col(q)) > 0) blk(k, pos(a%col(q))) = a%val(q)
        end do
      end do
      do k = 1, m
        pos(idx(ptr(p) + k - 1)) = 0
      end do
      off = ps%foff(p)
      call dense_cholesky_packed(blk(1:m, 1:m), ps%fac(off:ps%foff(p + 1) - 1), ierr)
      if (ierr /= 0) then
        call set_error(st, DS_ERR_NUMERIC, 'patch Schwarz: the block of patch ' // itoa(p) // &
          ' is not positive definite')
        return
      end if
    end do
  end subroutine patch_schwarz_setup

  !> Cholesky factor L (packed lower, column by column) of the SPD block blk; ierr /= 0
  !> when a pivot is not positive.
  pure subroutine dense_cholesky_packed(blk, l, ierr)
    real(dp), intent(inout) :: blk(:,:)
    real(dp), intent(out) :: l(:)
    integer, intent(out) :: ierr
    integer :: m, j, i, k, off
    m = size(blk, 1)
    ierr = 0
    do j = 1, m
      do k = 1, j - 1
        blk(j:m, j) = blk(j:m, j) - blk(j:m, k) * blk(j, k)
      end do
      if (.not. blk(j, j) > 0.0_dp) then
        ierr = j
        return
      end if
      blk(j, j) = sqrt(blk(j, j))
      blk(j + 1:m, j) = blk(j + 1:m, j) / blk(j, j)
    end do
    off = 0
    do j = 1, m
      do i = j, m
        off = off + 1
        l(off) = blk(i, j)
      end do
    end do
  end subroutine dense_cholesky_packed

  !> z = M^{-1} r (sum over the patches of the local solves).
  pure subroutine patch_schwarz_apply(ps, r, z)
    type(patch_schwarz_t), intent(in) :: ps
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: z(:)
    real(dp) :: y(ps%max_size)
    integer :: p, m, j, i, off, base
    z = 0.0_dp
    do p = 1, ps%npatch
      base = ps%ptr(p) - 1
      m = ps%ptr(p + 1) - ps%ptr(p)
      if (m == 0) cycle
      y(1:m) = r(ps%idx(base + 1:base + m))
      ! forward L y = r, then backward L^T y = y (packed columns)
      off = int(ps%foff(p)) - 1
      do j = 1, m
        y(j) = y(j) / ps%fac(off + 1)
        do i = j + 1, m
          y(i) = y(i) - ps%fac(off + i - j + 1) * y(j)
        end do
        off = off + m - j + 1
      end do
      do j = m, 1, -1
        off = off - (m - j + 1)
        do i = j + 1, m
          y(j) = y(j) - ps%fac(off + i - j + 1) * y(i)
        end do
        y(j) = y(j) / ps%fac(off + 1)
      end do
      do j = 1, m
        i = ps%idx(base + j)
        z(i) = z(i) + y(j)
      end do
    end do
  end subroutine patch_schwarz_apply

  !> Preconditioned CG (the V-cycle of h) for min J(x) = 1/2 x^T A x - b^T x, A the finest
  !> matrix of h, over the unknowns with free(i); the others keep their values in x.  Stops
  !> when the decrease of J in a step is at most rel (J(x) - j_floor), or after max_iter
  !> steps (converged false).  h has at least two levels.  Out of memory: DS_ERR_MEMORY in st.
  subroutine pcg_quadratic(h, b, free, j_floor, rel, max_iter, x, res, st)
    type(mg_hierarchy_t), intent(in) :: h
    real(dp), intent(in) :: b(:)
    logical, intent(in) :: free(:)
    real(dp), intent(in) :: j_floor, rel
    integer, intent(in) :: max_iter
    real(dp), intent(inout) :: x(:)
    type(pcg_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), allocatable :: r(:), z(:), p(:), ap(:)
    real(dp) :: rz, rz_new, alpha, beta, pap, jx
    integer :: k, ist
    associate (a => h%lev(h%nlevel)%a)
    allocate (r(a%n), z(a%n), p(a%n), ap(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the conjugate gradient vectors', 4 * a%n, BYTES_REAL)) return
    call csr_matvec(a, x, ap)
    jx = 0.5_dp * dot_product(x, ap) - dot_product(b, x)
    r = b - ap
    where (.not. free) r = 0.0_dp
    call vcycle(h, h%nlevel, h%nlevel, r, z, st)
    if (st%code /= 0) return
    p = z
    rz = dot_product(r, z)
    do k = 1, max_iter
      if (.not. rz > 0.0_dp) then
        res%converged = .true.
        exit
      end if
      call csr_matvec(a, p, ap)
      where (.not. free) ap = 0.0_dp
      pap = dot_product(p, ap)
      if (.not. pap > 0.0_dp) exit
      alpha = rz / pap
      x = x + alpha * p
      r = r - alpha * ap
      res%iterations = k
      res%last_decrease = 0.5_dp * alpha * rz
      jx = jx - res%last_decrease
      if (res%last_decrease <= rel * (jx - j_floor)) then
        res%converged = .true.
        exit
      end if
      call vcycle(h, h%nlevel, h%nlevel, r, z, st)
      if (st%code /= 0) return
      rz_new = dot_product(r, z)
      beta = rz_new / rz
      rz = rz_new
      p = z + beta * p
    end do
    res%j_value = jx
    end associate
  end subroutine pcg_quadratic
end module dualsig_patch_schwarz
