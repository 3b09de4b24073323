!> Smoothed aggregation (Vanek, Mandel & Brezina 1996): the prolongation of one level of an
!> algebraic multigrid hierarchy built from a symmetric positive (semi-)definite matrix alone,
!> for meshes that come without a hierarchy of refinements (level 1 of a run, Gmsh meshes,
!> adaptive steps).
!>
!>  1. strength of connection: j is a strong neighbour of i when
!>     |a_ij| >= amg_strength_theta * sqrt(a_ii a_jj), or when
!>     |a_ij| >= amg_strength_theta_min * min(a_ii, a_jj) (a node far stiffer than its
!>     neighbours stays connected to them);
!>  2. greedy aggregation in the three phases of Vanek-Mandel-Brezina: (1) a node none of
!>     whose strong neighbours is aggregated yet starts an aggregate with all of them;
!>     (2) the nodes left join the aggregate of a strong neighbour (the strongest one);
!>     (3) the nodes still left form aggregates with their free strong neighbours (a node
!>     without any strong neighbour is an aggregate of its own).  The nodes are visited in
!>     the order given (amg_sweep_order: by the coordinates, row by row, when the caller
!>     has them), else in their numbering.  The greedy phase 1 grows regular aggregates
!>     when consecutive nodes are neighbours, as on a grid numbered row by row; a mesh
!>     numbered by its refinements (the coarse nodes first, scattered) took 54 V-cycles at
!>     2.6e5 unknowns in its numbering against 17 for the same grid numbered row by row;
!>  3. the tentative prolongation P_tent: piecewise constant per aggregate (the near kernel
!>     of a scalar elliptic operator is the constants);
!>  4. the smoothed prolongation P = (I - omega D_F^-1 A_F) P_tent with the filtered matrix
!>     A_F (the weak connections lumped into the diagonal: row sums kept, fill limited to
!>     the strong graph) and omega = 4 / (3 rho), rho = the Gershgorin bound
!>     max_i sum_j |a^F_ij| / a^F_ii of rho(D_F^-1 A_F) (an upper bound, so omega is safe
!>     without power iterations; on P1 and P2 Laplacians it is within 1.5 of rho).
!> The Galerkin product P^T A P (amg_galerkin_product, amg_galerkin_values) is also used by
!> the truncated multigrid, whose frozen unknowns are the zeroed rows of P
!> (dualsig_solver_multigrid): the aggregation is built on the full matrix, all nodes
!> included, and the truncation does the rest.
!>
!> Why an own aggregation and not hypre's BoomerAMG: hypre is packaged by Debian, but
!> Debian's libhypre is built against MPI, and a sequential Fortran library that its legacy
!> users link without MPI must not pull MPI in.
module dualsig_amg_aggregation
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, rect_t, csr_set_row_pattern, sort_small_ints
  use dualsig_status, only: status_t, is_ok, set_error, DS_ERR_NUMERIC
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: amg_strength_theta, amg_strength_theta_min, amg_coarsest_max
  public :: amg_prolongation, amg_transpose, amg_galerkin_product, amg_galerkin_values, amg_sweep_order

  !> Strength threshold of the connection graph (0.08: Vanek-Mandel-Brezina's choice for
  !> 2D; every edge of a P1 Laplacian on a shape-regular mesh is strong).
  real(dp), parameter :: amg_strength_theta = 0.08_dp
  !> j is also a strong neighbour of i when |a_ij| >= amg_strength_theta_min min(a_ii, a_jj).
  !> This acts only where one diagonal is about ten times the other ((0.25/0.08)^2): a node
  !> far stiffer than its neighbours, such as a merged run of Gamma_a vertices of the stream
  !> function (one unknown coupled to every vertex along the run).  The scaled test alone
  !> makes such a node isolated; its neighbours' couplings to it are then lumped into their
  !> diagonals, and the coarse spaces treat it as a free boundary where the fine operator
  !> holds it like a fixed one: 20-46 V-cycles per solve on the graded meshes of an adaptive
  !> run, against 9-12 with this test (doc/performance.md).
  real(dp), parameter :: amg_strength_theta_min = 0.25_dp
  !> Coarsening stops when a grid has at most this many unknowns (solved by CHOLMOD).
  integer, parameter :: amg_coarsest_max = 2000

contains

  !> The smoothed-aggregation prolongation p (a%n x nc, module header) of the matrix a and
  !> the aggregate agg(i) in 1..nc of every node.  st: DS_ERR_MEMORY when out of memory.
  !> order: the visiting order of the aggregation (a permutation of 1..a%n, e.g. from
  !> amg_sweep_order); absent: the numbering.
  subroutine amg_prolongation(a, p, agg, st, order)
    type(csr_t), intent(in) :: a
    type(rect_t), intent(out) :: p
    integer, allocatable, intent(out) :: agg(:)
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: order(:)
    logical, allocatable :: strong(:)
    integer, allocatable :: natural(:)
    integer :: nagg, ist, i
    allocate (strong(size(a%val)), agg(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the strength graph of the aggregation', size(a%val) + a%n, BYTES_INT)) return
    call strength_graph(a, strong)
    if (present(order)) then
      call aggregate(a, strong, order, agg, nagg)
    else
      allocate (natural(a%n), stat=ist)
      if (alloc_failed(ist, st, 'the order of the aggregation', a%n, BYTES_INT)) return
      natural = [(i, i = 1, a%n)]
      call aggregate(a, strong, natural, agg, nagg)
      deallocate (natural)
    end if
    call smooth_prolongation(a, strong, agg, nagg, p, st)
  end subroutine amg_prolongation

  !> strong(p) for every stored entry p of a: the off-diagonal entry is a strong connection.
  pure subroutine strength_graph(a, strong)
    type(csr_t), intent(in) :: a
    logical, intent(out) :: strong(:)
    integer :: i, p, j
    do i = 1, a%n
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        j = a%col(p)
        strong(p) = j /= i .and. (abs(a%val(p)) >= amg_strength_theta * sqrt(abs(a%val(a%diag(i)) * a%val(a%diag(j)))) &
                    .or. abs(a%val(p)) >= amg_strength_theta_min * min(abs(a%val(a%diag(i))), abs(a%val(a%diag(j)))))
      end do
    end do
  end subroutine strength_graph

  !> The sweep order of nodes with coordinates xy(2, n): by y, equal y by x (row by row on
  !> a structured grid whatever its numbering; a sweep upwards on an unstructured mesh).
  !> A stable bottom-up merge sort.  st: DS_ERR_MEMORY.
  subroutine amg_sweep_order(xy, order, st)
    real(dp), intent(in) :: xy(:,:)
    integer, allocatable, intent(out) :: order(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: tmp(:)
    integer :: n, width, lo, mid, hi, ist, i
    n = size(xy, 2)
    allocate (order(n), tmp(n), stat=ist)
    if (alloc_failed(ist, st, 'the sweep order of the aggregation', 2 * n, BYTES_INT)) return
    order = [(i, i = 1, n)]
    width = 1
    do while (width < n)
      do lo = 1, n, 2 * width
        mid = min(lo + width - 1, n)
        hi = min(lo + 2 * width - 1, n)
        if (mid < hi) call merge_runs(xy, order(lo:mid), order(mid + 1:hi), tmp(lo:hi))
        if (mid < hi) order(lo:hi) = tmp(lo:hi)
      end do
      width = 2 * width
    end do
  end subroutine amg_sweep_order

  !> Merge the sorted runs left and right (by y, then x; left first on ties) into out.
  pure subroutine merge_runs(xy, left, right, out)
    real(dp), intent(in) :: xy(:,:)
    integer, intent(in) :: left(:), right(:)
    integer, intent(out) :: out(:)
    integer :: i, j, k
    i = 1
    j = 1
    do k = 1, size(out)
      if (j > size(right)) then
        out(k) = left(i)
        i = i + 1
      else if (i > size(left)) then
        out(k) = right(j)
        j = j + 1
      else if (before(right(j), left(i))) then
        out(k) = right(j)
        j = j + 1
      else
        out(k) = left(i)
        i = i + 1
      end if
    end do
  contains
    pure logical function before(u, v)
      integer, intent(in) :: u, v
      before = xy(2, u) < xy(2, v) .or. (xy(2, u) == xy(2, v) .and. xy(1, u) < xy(1, v))
    end function before
  end subroutine merge_runs

  !> The aggregate agg(i) in 1..nagg of every node (the three phases of the module header),
  !> the nodes visited in the given order.
  pure subroutine aggregate(a, strong, order, agg, nagg)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: strong(:)
    integer, intent(in) :: order(:)
    integer, intent(out) :: agg(:)
    integer, intent(out) :: nagg
    integer :: i, k, p, j, best
    real(dp) :: w, wbest
    logical :: free
    agg = 0
    nagg = 0
    do k = 1, a%n                                     ! phase 1: whole free neighbourhoods
      i = order(k)
      free = .true.
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (strong(p) .and. agg(a%col(p)) /= 0) free = .false.
      end do
      if (.not. free .or. agg(i) /= 0) cycle
      if (.not. any(strong(a%rowptr(i):a%rowptr(i + 1) - 1))) cycle
      nagg = nagg + 1
      agg(i) = nagg
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (strong(p)) agg(a%col(p)) = nagg
      end do
    end do
    do k = 1, a%n                                     ! phase 2: join the strongest aggregated neighbour
      i = order(k)
      if (agg(i) /= 0) cycle
      best = 0
      wbest = -1.0_dp
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        j = a%col(p)
        if (.not. strong(p) .or. agg(j) <= 0) cycle
        w = abs(a%val(p))
        if (w > wbest) then
          wbest = w
          best = agg(j)
        end if
      end do
      if (best > 0) agg(i) = -best                    ! (negative: not a phase-1 node, see below)
    end do
    agg = abs(agg)
    do k = 1, a%n                                     ! phase 3: the rest with their free neighbours
      i = order(k)
      if (agg(i) /= 0) cycle
      nagg = nagg + 1
      agg(i) = nagg
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        if (strong(p) .and. agg(a%col(p)) == 0) agg(a%col(p)) = nagg
      end do
    end do
  end subroutine aggregate

  !> p = (I - omega D_F^-1 A_F) P_tent (module header), columns sorted in each row.
  subroutine smooth_prolongation(a, strong, agg, nagg, p, st)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: strong(:)
    integer, intent(in) :: agg(:), nagg
    type(rect_t), intent(out) :: p
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: dfil(:), acc(:)
    integer, allocatable :: pos(:), list(:)
    real(dp) :: rho, s, omega
    integer :: i, q, j, nnz, ist, cnt, k, c
    logical :: isolated
    allocate (dfil(a%n), acc(nagg), pos(nagg), list(nagg), p%rowptr(a%n + 1), stat=ist)
    if (alloc_failed(ist, st, 'the smoothed prolongation', 3 * a%n + 3 * nagg, BYTES_REAL)) return
    rho = 0.0_dp
    nnz = 0
    do i = 1, a%n                         ! filtered diagonal, Gershgorin bound, row lengths
      dfil(i) = a%val(a%diag(i))
      s = 0.0_dp
      do q = a%rowptr(i), a%rowptr(i + 1) - 1
        if (a%col(q) /= i .and. .not. strong(q)) dfil(i) = dfil(i) + a%val(q)
        if (strong(q)) s = s + abs(a%val(q))
      end do
      if (.not. dfil(i) > 0.0_dp) dfil(i) = a%val(a%diag(i))
      if (s > 0.0_dp) rho = max(rho, 1.0_dp + s / dfil(i))
      nnz = nnz + count(strong(a%rowptr(i):a%rowptr(i + 1) - 1)) + 1
    end do
    omega = 4.0_dp / (3.0_dp * rho)
    p%m = a%n
    p%n = nagg
    allocate (p%col(nnz), p%val(nnz), stat=ist)
    if (alloc_failed(ist, st, 'the smoothed prolongation', 3 * nnz, BYTES_INT)) return
    pos = 0
    acc = 0.0_dp
    nnz = 0
    p%rowptr(1) = 1
    do i = 1, a%n
      cnt = 0
      ! a node without strong neighbours keeps its tentative row: its filtered row is its
      ! row sum alone, and smoothing would scale the row by 1 - omega wherever that sum is
      ! not exactly zero, so that P 1 /= 1 there (a merged Gamma_a chain of the stream
      ! function, whose row sum is its diagonal shift: multigrid then stalled at a residual
      ! proportional to the shift)
      isolated = .not. any(strong(a%rowptr(i):a%rowptr(i + 1) - 1))
      do q = a%rowptr(i), a%rowptr(i + 1) - 1
        j = a%col(q)
        if (j /= i .and. .not. strong(q)) cycle
        c = agg(j)
        if (pos(c) == 0) then
          cnt = cnt + 1
          list(cnt) = c
          pos(c) = cnt
        end if
        if (j == i .and. isolated) then
          acc(c) = acc(c) + 1.0_dp
        else if (j == i) then
          acc(c) = acc(c) + 1.0_dp - omega
        else
          acc(c) = acc(c) - omega * a%val(q) / dfil(i)
        end if
      end do
      call sort_small_ints(list(1:cnt))
      do k = 1, cnt
        c = list(k)
        if (acc(c) /= 0.0_dp) then
          nnz = nnz + 1
          p%col(nnz) = c
          p%val(nnz) = acc(c)
        end if
        acc(c) = 0.0_dp
        pos(c) = 0
      end do
      p%rowptr(i + 1) = nnz + 1
    end do
  end subroutine smooth_prolongation

  !> pt = p^T (n x m), columns sorted in each row.  st: DS_ERR_MEMORY.
  subroutine amg_transpose(p, pt, st)
    type(rect_t), intent(in) :: p
    type(rect_t), intent(out) :: pt
    type(status_t), intent(inout) :: st
    integer, allocatable :: fill(:)
    integer :: i, q, c, nnz, ist
    nnz = p%rowptr(p%m + 1) - 1
    pt%m = p%n
    pt%n = p%m
    allocate (pt%rowptr(p%n + 1), fill(p%n), pt%col(nnz), pt%val(nnz), stat=ist)
    if (alloc_failed(ist, st, 'the restriction of the aggregation', 2 * p%n + 3 * nnz, BYTES_INT)) return
    fill = 0
    do q = 1, nnz
      fill(p%col(q)) = fill(p%col(q)) + 1
    end do
    pt%rowptr(1) = 1
    do c = 1, p%n
      pt%rowptr(c + 1) = pt%rowptr(c) + fill(c)
    end do
    fill = 0
    do i = 1, p%m                             ! rows in increasing order: sorted columns
      do q = p%rowptr(i), p%rowptr(i + 1) - 1
        c = p%col(q)
        pt%col(pt%rowptr(c) + fill(c)) = i
        pt%val(pt%rowptr(c) + fill(c)) = p%val(q)
        fill(c) = fill(c) + 1
      end do
    end do
  end subroutine amg_transpose

  !> ac = P^T af P with p (nf x nc) and pt = p^T: pattern and values in one sweep over the
  !> product (Gustavson's row-by-row product: a dense accumulator and a marker per coarse
  !> column), columns sorted, the diagonal always stored.  The row lengths are not known
  !> before the sweep, so the entries go to arrays that grow by half when full (from a guess
  !> of nnz(af) nc / nf + nc) and are cut to size at the end.  The values are those of the
  !> untruncated product; amg_galerkin_values recomputes them on this pattern (truncated,
  !> or after af changed).  st: DS_ERR_MEMORY, DS_ERR_NUMERIC (2^31 entries or more).
  subroutine amg_galerkin_product(p, pt, af, ac, st)
    type(rect_t), intent(in) :: p, pt
    type(csr_t), intent(in) :: af
    type(csr_t), intent(out) :: ac
    type(status_t), intent(inout) :: st
    integer, allocatable :: mark(:), list(:), col(:)
    real(dp), allocatable :: acc(:), val(:)
    integer :: ci, q, r, s, i, j, jc, cnt, ist
    integer(i8) :: nnz, cap
    real(dp) :: aij
    allocate (mark(p%n), list(p%n), acc(p%n), ac%rowptr(p%n + 1), ac%diag(p%n), stat=ist)
    if (alloc_failed(ist, st, 'the pattern of a coarse operator', 6_i8 * p%n, BYTES_INT)) return
    ac%n = p%n
    cap = int(real(size(af%col), dp) * real(p%n, dp) / real(max(1, af%n), dp), i8) + p%n
    allocate (col(cap), val(cap), stat=ist)
    if (alloc_failed(ist, st, 'a coarse operator', cap, BYTES_INT + BYTES_REAL)) return
    mark = 0
    nnz = 0
    ac%rowptr(1) = 1
    do ci = 1, p%n
      cnt = 1
      list(1) = ci
      mark(ci) = ci
      acc(ci) = 0.0_dp
      do q = pt%rowptr(ci), pt%rowptr(ci + 1) - 1
        i = pt%col(q)
        do r = af%rowptr(i), af%rowptr(i + 1) - 1
          j = af%col(r)
          aij = pt%val(q) * af%val(r)
          do s = p%rowptr(j), p%rowptr(j + 1) - 1
            jc = p%col(s)
            if (mark(jc) /= ci) then
              mark(jc) = ci
              cnt = cnt + 1
              list(cnt) = jc
              acc(jc) = 0.0_dp
            end if
            acc(jc) = acc(jc) + aij * p%val(s)
          end do
        end do
      end do
      call sort_small_ints(list(1:cnt))
      if (nnz + cnt > cap) then
        call grow(max(nnz + cnt, cap + cap / 2))
        if (.not. is_ok(st)) return
      end if
      col(nnz + 1:nnz + cnt) = list(1:cnt)
      val(nnz + 1:nnz + cnt) = acc(list(1:cnt))
      ac%diag(ci) = int(nnz) + findloc(list(1:cnt), ci, 1)
      nnz = nnz + cnt
      if (nnz >= huge(1)) then
        call set_error(st, DS_ERR_NUMERIC, 'a coarse operator: more than 2^31 - 1 entries')
        return
      end if
      ac%rowptr(ci + 1) = int(nnz) + 1
    end do
    allocate (ac%col(nnz), ac%val(nnz), stat=ist)
    if (alloc_failed(ist, st, 'a coarse operator', nnz, BYTES_INT + BYTES_REAL)) return
    ac%col = col(1:nnz)
    ac%val = val(1:nnz)
  contains
    subroutine grow(newcap)
      integer(i8), intent(in) :: newcap
      integer, allocatable :: col2(:)
      real(dp), allocatable :: val2(:)
      allocate (col2(newcap), val2(newcap), stat=ist)
      if (alloc_failed(ist, st, 'a coarse operator', newcap, BYTES_INT + BYTES_REAL)) return
      col2(1:nnz) = col(1:nnz)
      val2(1:nnz) = val(1:nnz)
      call move_alloc(col2, col)
      call move_alloc(val2, val)
      cap = newcap
    end subroutine grow
  end subroutine amg_galerkin_product

  !> The values of ac = P_T^T af P_T on the pattern of amg_galerkin_product, P_T = p with
  !> the rows of the frozen fine unknowns zeroed (frozen absent: none).  pos(p%n) is
  !> scratch, zero on entry and on return; ok set .false. when an entry leaves the pattern.
  !> rows present: only the coarse rows ci with rows(ci) are computed.
  pure subroutine amg_galerkin_values(p, pt, af, ac, pos, ok, frozen, rows)
    type(rect_t), intent(in) :: p, pt
    type(csr_t), intent(in) :: af
    type(csr_t), intent(inout) :: ac
    integer, intent(inout) :: pos(:)
    logical, intent(inout) :: ok
    logical, intent(in), optional :: frozen(:)
    logical, intent(in), optional :: rows(:)
    integer :: ci, q, r, s, i, j, k, lo, hi
    real(dp) :: wi, aij
    logical :: truncated
    truncated = present(frozen)
    do ci = 1, p%n
      if (present(rows)) then
        if (.not. rows(ci)) cycle
      end if
      lo = ac%rowptr(ci)
      hi = ac%rowptr(ci + 1) - 1
      do k = lo, hi
        pos(ac%col(k)) = k
      end do
      ac%val(lo:hi) = 0.0_dp
      do q = pt%rowptr(ci), pt%rowptr(ci + 1) - 1
        i = pt%col(q)
        if (truncated) then
          if (frozen(i)) cycle
        end if
        wi = pt%val(q)
        do r = af%rowptr(i), af%rowptr(i + 1) - 1
          j = af%col(r)
          if (truncated) then
            if (frozen(j)) cycle
          end if
          aij = wi * af%val(r)
          do s = p%rowptr(j), p%rowptr(j + 1) - 1
            k = pos(p%col(s))
            if (k == 0) then
              ok = .false.
              cycle
            end if
            ac%val(k) = ac%val(k) + aij * p%val(s)
          end do
        end do
      end do
      do k = lo, hi
        pos(ac%col(k)) = 0
      end do
    end do
  end subroutine amg_galerkin_values

end module dualsig_amg_aggregation
