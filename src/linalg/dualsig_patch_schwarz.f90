!> Schwarz smoothing with small dense blocks ("patches"), the multigrid V-cycle built on
!> it, and the flexible preconditioned conjugate gradient method on a subset of the unknowns.
!>
!> A patch is a list of unknowns; a multiplicative sweep updates z_P = z_P + A_PP^{-1}
!> (r - A z)_P patch after patch, each block factorised once by a dense Cholesky
!> factorisation (packed lower triangle).  With the vertex patches of Arnold, Falk and
!> Winther (all unknowns of the edges at a vertex) it is the smoother of their H(div)
!> multigrid, robust on the discretely divergence-free components where point (Jacobi)
!> blocks are not.
!>
!> A hierarchy of nested spaces (mg_hierarchy_t: level matrices A_l, prolongations P_l from
!> level l-1 to l, the patches of every level, A_1 factorised by CHOLMOD) gives the
!> V-cycle used as preconditioner: a forward sweep, the coarse correction P_l (V-cycle of
!> level l-1) P_l^T, a second forward sweep (not symmetric: the CG is flexible).  Every
!> level has a set of `held` unknowns (zero in its correction space); mg_hold sets them
!> from the finest level's free unknowns and takes them out of the patches (the patches
!> with `bounded` unknowns are factorised again).  A coarse space must hold what the
!> finer one holds after prolongation (e.g. a zero normal trace on a boundary), or the
!> truncated coarse corrections do not match the coarse matrices.
!>
!> pcg_quadratic minimises J(x) = 1/2 x^T A x - b^T x (A the finest level's matrix) over
!> the unknowns marked free (the others keep their values; the preconditioner is truncated
!> to the free unknowns) and stops when the last decrease of J is at most `rel` times
!> J(x) - j_floor, j_floor a lower bound of J supplied by the caller (the decrease per step
!> relative to what is left to gain at most: a computable criterion).
module dualsig_patch_schwarz
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, csr_matvec, csr_move, rect_t, rect_matvec, rect_matvec_t, rect_move
  use dualsig_spd_solver, only: cholmod_spd_t
  use dualsig_status, only: status_t, set_error, DS_ERR_NUMERIC, DS_ERR_MEMORY
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: patch_schwarz_t, patch_schwarz_setup, pcg_quadratic, pcg_result_t
  public :: mg_hierarchy_t, mg_add_level, mg_free, mg_hold, mg_max_levels, mg_relax_bounded

  !> Most levels of a hierarchy.
  integer, parameter :: mg_max_levels = 24

  !> The patches and the Cholesky factors of their blocks.  The unknowns of patch p in use
  !> (not held) come first: idx(ptr(p):ptr(p)+nact(p)-1), the block of these factorised.
  type :: patch_schwarz_t
    integer :: npatch = 0
    integer :: max_size = 0              !! largest patch
    integer, allocatable :: ptr(:)       !! (npatch+1) patch p is idx(ptr(p):ptr(p+1)-1)
    integer, allocatable :: idx(:)       !! unknowns of the patches
    integer, allocatable :: nact(:)      !! (npatch) unknowns of patch p in use
    integer, allocatable :: touch(:)     !! the patches with a bounded unknown (factorised again by mg_hold)
    integer(i8), allocatable :: foff(:) !! (npatch+1) factor of p is fac(foff(p):foff(p+1)-1)
    !> packed lower Cholesky factors, column by column, each diagonal entry stored as its
    !> reciprocal (the substitutions multiply)
    real(dp), allocatable :: fac(:)
  end type patch_schwarz_t

  !> One level of a hierarchy.
  type :: mg_level_t
    type(csr_t) :: a                     !! the level's matrix
    type(rect_t) :: p                    !! prolongation from level l-1 (levels >= 2)
    type(patch_schwarz_t) :: ps          !! the smoother's patches (levels >= 2)
    logical, allocatable :: bounded(:)   !! unknowns that may be held
    logical, allocatable :: held(:)      !! unknowns held at zero (mg_hold)
    real(dp), allocatable :: r(:), z(:), w(:)  !! work vectors of the V-cycle (right side, correction, residual)
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
    real(dp) :: j_start = 0.0_dp         !! J at the start
    !> decrease of the last step over that of the step before (0 after fewer than 2 steps)
    real(dp) :: step_ratio = 0.0_dp
    logical :: predicted_stop = .false.  !! stopped on the predicted next decrease
  end type pcg_result_t

  !> pcg_quadratic: the predicted next decrease is the last one times this multiple of the
  !> caller's ratio (a margin for its variation between levels).
  real(dp), parameter :: ratio_margin = 3.0_dp

contains

  !> Append a finer level: its matrix a and (from the second level on) the prolongation p
  !> from the previous level (both moved into the hierarchy), its patches ptr/idx
  !> factorised without the bounded unknowns (mg_hold puts the free ones back); the first
  !> level's matrix is factorised by mg_hold.
  subroutine mg_add_level(h, a, p, ptr, idx, bounded, st)
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(inout) :: a
    type(rect_t), intent(inout) :: p
    integer, intent(in) :: ptr(:), idx(:)
    logical, intent(in) :: bounded(:)
    type(status_t), intent(out) :: st
    integer :: l, ierr
    if (h%nlevel == mg_max_levels) then
      call set_error(st, DS_ERR_NUMERIC, 'multigrid: more than ' // itoa(mg_max_levels) // ' levels')
      return
    end if
    l = h%nlevel + 1
    st%code = 0
    if (l > 1) then
      call patch_schwarz_setup(a, ptr, idx, bounded, h%lev(l)%ps, st)
      if (st%code /= 0) return
      call rect_move(p, h%lev(l)%p)
    end if
    allocate (h%lev(l)%r(a%n), h%lev(l)%z(a%n), h%lev(l)%w(a%n), stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_MEMORY, 'multigrid: out of memory (' // itoa(a%n) // ' unknowns)')
      return
    end if
    call csr_move(a, h%lev(l)%a)
    h%lev(l)%bounded = bounded
    h%lev(l)%held = bounded
    h%nlevel = l
  end subroutine mg_add_level

  !> Hold the unknowns of the finest level that are not free, and on every coarser level
  !> the bounded unknowns whose prolongation reaches a held finer one (so that coarse
  !> corrections never touch a held unknown); the patches with bounded unknowns are
  !> factorised again without the held ones, and the coarsest matrix with the rows and
  !> columns of its held unknowns those of the identity.
  subroutine mg_hold(h, free, st)
    type(mg_hierarchy_t), intent(inout) :: h
    logical, intent(in) :: free(:)
    type(status_t), intent(out) :: st
    type(csr_t) :: a_held
    integer :: l, i, q
    st%code = 0
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
      call patch_schwarz_refactor(h%lev(l)%a, h%lev(l)%held, h%lev(l)%ps, st)
      if (st%code /= 0) return
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

  !> lev(l)%z = B lev(l)%r, B the V-cycle of level l: a forward multiplicative sweep over
  !> the patches, the coarse correction P_l (V-cycle of level l-1) P_l^T of the residual,
  !> and a second forward sweep.  B is not symmetric (the symmetric cycle's second sweep
  !> runs backward, which costs 2.3 times a forward sweep here: the patches' factors and
  !> rows are laid out in the forward order, see doc/performance.md), so pcg_quadratic is
  !> a flexible CG.  Each sweep and the coarse correction reduce the A-norm of the error,
  !> so r^T B r > 0 for r /= 0.  r is zero on the held unknowns, and so is z.
  recursive subroutine vcycle(h, l)
    type(mg_hierarchy_t), intent(inout) :: h
    integer, intent(in) :: l
    type(status_t) :: st
    integer :: i
    if (l == 1) then
      associate (lv => h%lev(1))
        call h%coarse%solve(lv%r, lv%z, st)
        where (lv%held) lv%z = 0.0_dp
      end associate
      return
    end if
    associate (lv => h%lev(l), lc => h%lev(l - 1))
      lv%z = 0.0_dp
      call patch_sweep(lv%a, lv%ps, lv%r, lv%z, .true.)
      call csr_matvec(lv%a, lv%z, lv%w)
      do i = 1, lv%a%n
        lv%w(i) = merge(0.0_dp, lv%r(i) - lv%w(i), lv%held(i))
      end do
      call rect_matvec_t(lv%p, lv%w, lc%r)
      where (lc%held) lc%r = 0.0_dp
      call vcycle(h, l - 1)
      call rect_matvec(lv%p, lc%z, lv%w)
      do i = 1, lv%a%n
        if (.not. lv%held(i)) lv%z(i) = lv%z(i) + lv%w(i)
      end do
      call patch_sweep(lv%a, lv%ps, lv%r, lv%z, .true.)
    end associate
  end subroutine vcycle

  !> Symmetric multiplicative sweeps (forward, backward) of the finest level's patches with
  !> bounded unknowns (after mg_hold) for a x = b: each patch step minimises
  !> J(x) = 1/2 x^T a x - b^T x over the patch's free unknowns, so J does not increase.
  subroutine mg_relax_bounded(h, b, x, sweeps)
    type(mg_hierarchy_t), intent(in) :: h
    real(dp), intent(in) :: b(:)
    real(dp), intent(inout) :: x(:)
    integer, intent(in) :: sweeps
    integer :: k
    associate (lv => h%lev(h%nlevel))
      do k = 1, sweeps
        call patch_sweep(lv%a, lv%ps, b, x, .true., lv%ps%touch)
        call patch_sweep(lv%a, lv%ps, b, x, .false., lv%ps%touch)
      end do
    end associate
  end subroutine mg_relax_bounded

  !> One multiplicative Schwarz sweep for a z = r over the patches of ps (or of list),
  !> forward (the first patch first) or backward: z_P = z_P + A_PP^{-1} (r - a z)_P,
  !> patch after patch.
  pure subroutine patch_sweep(a, ps, r, z, forward, list)
    type(csr_t), intent(in) :: a
    type(patch_schwarz_t), intent(in) :: ps
    real(dp), intent(in) :: r(:)
    real(dp), intent(inout) :: z(:)
    logical, intent(in) :: forward
    integer, intent(in), optional :: list(:)   !! only these patches (in this order when forward)
    real(dp) :: y(ps%max_size), s
    integer :: ip, p, m, j, i, q, off, base, first, last, step, np
    np = ps%npatch
    if (present(list)) np = size(list)
    if (forward) then
      first = 1
      last = np
      step = 1
    else
      first = np
      last = 1
      step = -1
    end if
    do ip = first, last, step
      p = ip
      if (present(list)) p = list(ip)
      m = ps%nact(p)
      if (m == 0) cycle
      base = ps%ptr(p) - 1
      do j = 1, m
        i = ps%idx(base + j)
        s = r(i)
        do q = a%rowptr(i), a%rowptr(i + 1) - 1
          s = s - a%val(q) * z(a%col(q))
        end do
        y(j) = s
      end do
      ! forward L y = r, then backward L^T y = y (packed columns)
      off = int(ps%foff(p)) - 1
      do j = 1, m
        y(j) = y(j) * ps%fac(off + 1)
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
        y(j) = y(j) * ps%fac(off + 1)
      end do
      do j = 1, m
        i = ps%idx(base + j)
        z(i) = z(i) + y(j)
      end do
    end do
  end subroutine patch_sweep

  !> Factorise the blocks of the patches ptr/idx of the SPD matrix a (columns sorted),
  !> without the `bounded` unknowns (patch_schwarz_refactor puts the free ones back).
  !> Empty patches are allowed.  DS_ERR_NUMERIC when a block is not positive definite.
  subroutine patch_schwarz_setup(a, ptr, idx, bounded, ps, st)
    type(csr_t), intent(in) :: a
    integer, intent(in) :: ptr(:), idx(:)
    logical, intent(in) :: bounded(:)
    type(patch_schwarz_t), intent(out) :: ps
    type(status_t), intent(out) :: st
    integer :: p, m, ierr
    st%code = 0
    ps%npatch = size(ptr) - 1
    ps%ptr = ptr
    ps%idx = idx
    allocate (ps%foff(ps%npatch + 1), ps%nact(ps%npatch), stat=ierr)
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
    ps%touch = pack([(p, p = 1, ps%npatch)], [(any(bounded(idx(ptr(p):ptr(p + 1) - 1))), p = 1, ps%npatch)])
    allocate (ps%fac(ps%foff(ps%npatch + 1) - 1), stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_MEMORY, 'patch Schwarz: out of memory for the patch factors')
      return
    end if
    call factor_patches(a, bounded, [(p, p = 1, ps%npatch)], ps, st)
  end subroutine patch_schwarz_setup

  !> Factorise again the patches with bounded unknowns, without the held ones.
  subroutine patch_schwarz_refactor(a, held, ps, st)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: held(:)
    type(patch_schwarz_t), intent(inout) :: ps
    type(status_t), intent(out) :: st
    call factor_patches(a, held, ps%touch, ps, st)
  end subroutine patch_schwarz_refactor

  !> For each patch of `list`: its unknowns not held first (nact of them), their block of a
  !> factorised.
  subroutine factor_patches(a, held, list, ps, st)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: held(:)
    integer, intent(in) :: list(:)
    type(patch_schwarz_t), intent(inout) :: ps
    type(status_t), intent(out) :: st
    integer, allocatable :: pos(:)
    !> column 0 takes the entries of columns outside the patch (pos 0): no branch per entry
    real(dp) :: blk(ps%max_size, 0:ps%max_size)
    integer :: ip, p, m, i, k, q, ierr, b, e
    st%code = 0
    allocate (pos(a%n), source=0, stat=ierr)
    if (ierr /= 0) then
      call set_error(st, DS_ERR_MEMORY, 'patch Schwarz: out of memory (' // itoa(a%n) // ' unknowns)')
      return
    end if
    do ip = 1, size(list)
      p = list(ip)
      b = ps%ptr(p)
      e = ps%ptr(p + 1) - 1
      call partition_held(ps%idx(b:e), held, m)
      ps%nact(p) = m
      if (m == 0) cycle
      do k = 1, m
        pos(ps%idx(b + k - 1)) = k
      end do
      blk(1:m, 1:m) = 0.0_dp
      do k = 1, m
        i = ps%idx(b + k - 1)
        do q = a%rowptr(i), a%rowptr(i + 1) - 1
          blk(k, pos(a%col(q))) = a%val(q)
        end do
      end do
      do k = 1, m
        pos(ps%idx(b + k - 1)) = 0
      end do
      call dense_cholesky_packed(blk(1:m, 1:m), ps%fac(ps%foff(p):ps%foff(p) + int(m, i8) * (m + 1) / 2 - 1), ierr)
      if (ierr /= 0) then
        call set_error(st, DS_ERR_NUMERIC, 'patch Schwarz: the block of patch ' // itoa(p) // &
          ' is not positive definite')
        return
      end if
    end do
  end subroutine factor_patches

  !> Reorder the unknowns `list` so that those not held come first (stable), m of them.
  pure subroutine partition_held(list, held, m)
    integer, intent(inout) :: list(:)
    logical, intent(in) :: held(:)
    integer, intent(out) :: m
    integer :: buf(size(list)), k, nh
    m = 0
    nh = 0
    do k = 1, size(list)
      if (held(list(k))) then
        nh = nh + 1
        buf(nh) = list(k)
      else
        m = m + 1
        list(m) = list(k)
      end if
    end do
    list(m + 1:) = buf(1:nh)
  end subroutine partition_held

  !> Cholesky factor L (packed lower, column by column, the diagonal entries as their
  !> reciprocals, so that the substitutions multiply and the factorisation divides once per
  !> column) of the SPD block blk; ierr /= 0 when a pivot is not positive.
  pure subroutine dense_cholesky_packed(blk, l, ierr)
    real(dp), intent(inout) :: blk(:,:)
    real(dp), intent(out) :: l(:)
    integer, intent(out) :: ierr
    integer :: m, j, k, off
    real(dp) :: rdiag(size(blk, 1))
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
      rdiag(j) = 1.0_dp / sqrt(blk(j, j))       ! one division per column
      blk(j + 1:m, j) = blk(j + 1:m, j) * rdiag(j)
    end do
    off = 0
    do j = 1, m
      off = off + 1
      l(off) = rdiag(j)
      l(off + 1:off + m - j) = blk(j + 1:m, j)
      off = off + m - j
    end do
  end subroutine dense_cholesky_packed

  !> Flexible preconditioned CG (the V-cycle of h, not symmetric) for min J(x) =
  !> 1/2 x^T A x - b^T x, A the finest matrix of h, over the unknowns with free(i); the
  !> others keep their values in x.  Each step is an exact line search along p, and the
  !> next direction is the preconditioned residual made A-conjugate to p (Notay's flexible
  !> CG with one direction kept: beta = -(z^T A p) / (p^T A p)), so J decreases in every
  !> step by (r^T p)^2 / (2 p^T A p).  Stops
  !> when the decrease of J in a step is at most rel (J(x) - j_floor), or, with ratio > 0
  !> (the step_ratio of an earlier solve with the same kind of preconditioner, e.g. the
  !> previous level's: the V-cycle's contraction does not depend on h), when the NEXT
  !> step's decrease predicted as ratio_margin ratio times this one's is (saves the
  !> V-cycle of a step that would gain almost nothing), or after max_iter steps
  !> (converged false).  h has at least two levels.  Out of memory: DS_ERR_MEMORY in st.
  subroutine pcg_quadratic(h, b, free, j_floor, rel, max_iter, x, res, st, ratio)
    type(mg_hierarchy_t), intent(inout) :: h
    real(dp), intent(in) :: b(:)
    logical, intent(in) :: free(:)
    real(dp), intent(in) :: j_floor, rel
    integer, intent(in) :: max_iter
    real(dp), intent(inout) :: x(:)
    type(pcg_result_t), intent(out) :: res
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: ratio
    real(dp), allocatable :: r(:), p(:), ap(:)
    real(dp) :: rz, alpha, beta, pap, jx
    integer :: k, nf, ist
    nf = h%nlevel
    associate (a => h%lev(nf)%a)
    allocate (r(a%n), p(a%n), ap(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the conjugate gradient vectors', 3 * a%n, BYTES_REAL)) return
    call csr_matvec(a, x, ap)
    jx = 0.5_dp * dot_product(x, ap) - dot_product(b, x)
    res%j_start = jx
    r = merge(b - ap, 0.0_dp, free)
    h%lev(nf)%r = r
    call vcycle(h, nf)
    p = h%lev(nf)%z
    rz = dot_product(r, p)
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
      if (k > 1 .and. res%last_decrease > 0.0_dp) res%step_ratio = 0.5_dp * alpha * rz / res%last_decrease
      res%last_decrease = 0.5_dp * alpha * rz
      jx = jx - res%last_decrease
      if (res%last_decrease <= rel * (jx - j_floor)) then
        res%converged = .true.
        exit
      end if
      if (present(ratio)) then
        if (ratio > 0.0_dp .and. ratio_margin * ratio * res%last_decrease <= rel * (jx - j_floor)) then
          res%converged = .true.
          res%predicted_stop = .true.
          exit
        end if
      end if
      if (k == max_iter) exit
      h%lev(nf)%r = r
      call vcycle(h, nf)
      ! r is orthogonal to the last p (exact line search), so r^T p_new = r^T z
      beta = -dot_product(h%lev(nf)%z, ap) / pap
      rz = dot_product(r, h%lev(nf)%z)
      p = h%lev(nf)%z + beta * p
    end do
    res%j_value = jx
    end associate
  end subroutine pcg_quadratic
end module dualsig_patch_schwarz
