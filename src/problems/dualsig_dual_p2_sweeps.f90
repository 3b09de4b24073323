!> Matrix-free Gauss-Seidel sweeps for the P2 stream function of the P2 dual
!> (dualsig_dual_p2_stream): R^T K R z = R^T F, K the P2 stiffness matrix of the mesh and
!> psi = R z the change of basis of an active set on Gamma_a (stream_reduced_basis), without
!> forming R^T K R.
!>
!> The sweeps work on psi itself: z_i is psi at the node that carries it (node_of_z(i);
!> R is 1 there), and a step on z_i by d moves psi by d times column i of R.  Almost every
!> column of R is the unit vector of its node; the others (a merged run of Gamma_a, the
!> midpoints eliminated by a one-sided active row: O(sqrt N) of them) are listed apart
!> (p2_sweeper_t%zcode), so R^T is not stored.  The residual
!> of row i is (R^T (F - K psi))_i, with (K psi)_p gathered from the triangles at node p;
!> each triangle's 6 x 6 matrix is that of its shape class (dualsig_mesh_shapes: a uniform
!> refinement has at most 3 n0 classes), or computed where it is needed when the classes
!> are more than max_class_fraction of the triangles (a mesh without refinements).
!>
!> Memory: the triangles at every P2 node (4 bytes each, 6 per triangle), the class of each
!> triangle, the column codes, the sweep's order and the diagonal of R^T K R: about 30 bytes
!> per P2 value, against about 130 for the assembled R^T K R (whose first touch of fresh memory was most of its cost,
!> doc/performance.md).  Each sweep visits every triangle six times (36 products), about
!> one and a half times the products of a sweep on the assembled matrix.
module dualsig_dual_p2_sweeps
  use dualsig_kinds, only: dp, i8
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_shapes, only: shape_classes
  use dualsig_elements_p2, only: p2_dofs, p2_element_stiffness
  use dualsig_sparse, only: rect_t
  use dualsig_status, only: status_t, is_ok
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: p2_sweeper_t, p2_sweeper_build, p2_sweep, p2_sweeper_fits

  !> The element matrices are kept per shape class when the classes are at most this
  !> fraction of the triangles (their table then costs at most 72 bytes a triangle, against
  !> 4 for the class index); otherwise each visit computes its triangle's matrix.
  real(dp), parameter :: max_class_fraction = 0.25_dp
  !> Bits of a triangle's local number in an entry of p2_sweeper_t%at (8 (t - 1) + l - 1).
  integer, parameter :: local_bits = 3

  !> What the sweeps need besides the mesh: see the module header.
  type :: p2_sweeper_t
    integer :: nz = 0                      !! unknowns z
    integer :: n2 = 0                      !! P2 values psi (nnode + nedge)
    logical :: classes = .false.           !! element matrices per shape class (else computed)
    integer, allocatable :: cls(:)         !! (ntri) shape class of each triangle (classes)
    real(dp), allocatable :: ke(:,:,:)     !! (6, 6, nshape) element matrix of each class (classes)
    !> (n2+1) the triangles at P2 node p: at(at_ptr(p):at_ptr(p+1)-1), each entry
    !> 8 (t - 1) + l - 1 with l the node's local number in triangle t (p2_dofs order)
    integer, allocatable :: at_ptr(:), at(:)
    !> (nz) column i of R: zcode(i) = p > 0 the unit vector of node p (which carries z_i);
    !> zcode(i) = -k, the k-th of the other columns: its node spec_node(k), its entries
    !> (spec_p, spec_w)(spec_ptr(k):spec_ptr(k+1)-1)
    integer, allocatable :: zcode(:)
    integer, allocatable :: spec_node(:), spec_ptr(:), spec_p(:)
    real(dp), allocatable :: spec_w(:)
    real(dp), allocatable :: diag(:)       !! (nz) (R^T K R)_ii
    !> (nz) the order of the unknowns in a forward sweep: as the triangles, in the mesh's
    !> order, first reach their nodes (sweep_order)
    integer, allocatable :: order(:)
  end type p2_sweeper_t

contains

  !> .true. when the triangles of mesh can be numbered in p2_sweeper_t%at (8 ntri < 2^31).
  pure logical function p2_sweeper_fits(mesh)
    type(mesh_t), intent(in) :: mesh
    p2_sweeper_fits = mesh%ntri < ishft(huge(1), -local_bits)
  end function p2_sweeper_fits

  !> The sweeper of the change of basis rmat (n2 x nz) with node_of_z on mesh.
  !> st: DS_ERR_MEMORY.
  subroutine p2_sweeper_build(mesh, rmat, node_of_z, sw, st)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(in) :: rmat
    integer, intent(in) :: node_of_z(:)
    type(p2_sweeper_t), intent(out) :: sw
    type(status_t), intent(inout) :: st
    integer, allocatable :: rep(:)
    integer :: nshape, c, ist
    sw%n2 = rmat%m
    sw%nz = rmat%n
    call shape_classes(mesh, sw%cls, rep, nshape, st)
    if (.not. is_ok(st)) return
    sw%classes = nshape <= max_class_fraction * mesh%ntri
    if (sw%classes) then
      allocate (sw%ke(6, 6, nshape), stat=ist)
      if (alloc_failed(ist, st, 'the element matrices of the shape classes', 36_i8 * nshape, BYTES_REAL)) return
      do c = 1, nshape
        call p2_element_stiffness(mesh%xy(:, mesh%tri(:, rep(c))), sw%ke(:, :, c))
      end do
    else
      deallocate (sw%cls)
    end if
    call node_triangles(mesh, sw%n2, sw%at_ptr, sw%at, st)
    if (.not. is_ok(st)) return
    call column_codes(rmat, node_of_z, sw, st)
    if (.not. is_ok(st)) return
    allocate (sw%diag(sw%nz), stat=ist)
    if (alloc_failed(ist, st, 'the diagonal of the stream operator', int(sw%nz, i8), BYTES_REAL)) return
    call reduced_diagonal(mesh, rmat, sw)
    call sweep_order(mesh, sw, st)
  end subroutine p2_sweeper_build

  !> p2_sweeper_t%zcode and the lists of the columns of R that are not a unit vector: those
  !> that a row of R other than their node's own reaches (a merged vertex, an eliminated
  !> midpoint).  A node's own row is the unit row (i, 1) (stream_reduced_basis).
  subroutine column_codes(rmat, node_of_z, sw, st)
    type(rect_t), intent(in) :: rmat
    integer, intent(in) :: node_of_z(:)
    type(p2_sweeper_t), intent(inout) :: sw
    type(status_t), intent(inout) :: st
    integer, allocatable :: fill(:)
    integer :: p, q, i, k, nspec, ist
    allocate (sw%zcode(sw%nz), stat=ist)
    if (alloc_failed(ist, st, 'the columns of the stream basis', int(sw%nz, i8), BYTES_INT)) return
    sw%zcode = node_of_z
    do p = 1, rmat%m                          ! the columns other rows reach
      if (own_row(p)) cycle
      do q = rmat%rowptr(p), rmat%rowptr(p + 1) - 1
        sw%zcode(rmat%col(q)) = 0
      end do
    end do
    nspec = 0
    do i = 1, sw%nz
      if (sw%zcode(i) /= 0) cycle
      nspec = nspec + 1
      sw%zcode(i) = -nspec
    end do
    allocate (sw%spec_node(nspec), sw%spec_ptr(nspec + 1), fill(nspec), stat=ist)
    if (alloc_failed(ist, st, 'the columns of the stream basis', 3_i8 * nspec + 1, BYTES_INT)) return
    sw%spec_ptr = 0
    sw%spec_ptr(1) = 1
    do i = 1, sw%nz                           ! each list: its node first, then the other rows
      if (sw%zcode(i) > 0) cycle
      k = -sw%zcode(i)
      sw%spec_node(k) = node_of_z(i)
      sw%spec_ptr(k + 1) = 1
    end do
    do p = 1, rmat%m
      if (own_row(p)) cycle
      do q = rmat%rowptr(p), rmat%rowptr(p + 1) - 1
        k = -sw%zcode(rmat%col(q))
        sw%spec_ptr(k + 1) = sw%spec_ptr(k + 1) + 1
      end do
    end do
    do k = 1, nspec
      sw%spec_ptr(k + 1) = sw%spec_ptr(k + 1) + sw%spec_ptr(k)
    end do
    allocate (sw%spec_p(sw%spec_ptr(nspec + 1) - 1), sw%spec_w(sw%spec_ptr(nspec + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the columns of the stream basis', 3_i8 * sw%spec_ptr(nspec + 1), BYTES_INT)) return
    fill = sw%spec_ptr(1:nspec)
    do k = 1, nspec
      sw%spec_p(fill(k)) = sw%spec_node(k)
      sw%spec_w(fill(k)) = 1.0_dp
      fill(k) = fill(k) + 1
    end do
    do p = 1, rmat%m
      if (own_row(p)) cycle
      do q = rmat%rowptr(p), rmat%rowptr(p + 1) - 1
        k = -sw%zcode(rmat%col(q))
        sw%spec_p(fill(k)) = p
        sw%spec_w(fill(k)) = rmat%val(q)
        fill(k) = fill(k) + 1
      end do
    end do
  contains
    !> Row p of R is the unit row of the unknown its node carries.
    logical function own_row(p)
      integer, intent(in) :: p
      integer :: q0
      q0 = rmat%rowptr(p)
      own_row = .false.
      if (rmat%rowptr(p + 1) /= q0 + 1) return
      own_row = node_of_z(rmat%col(q0)) == p .and. rmat%val(q0) == 1.0_dp
    end function own_row
  end subroutine column_codes

  !> p2_sweeper_t%order: the unknowns as the triangles first reach the nodes that carry
  !> them.  The sweeps are bound by memory latency; the triangles of a refinement lie
  !> together (a parent's children are consecutive), the nodes do not (a level's new
  !> vertices and midpoints come after the old ones), so this keeps the psi values and
  !> triangles a step reads close to those of the step before.  st: DS_ERR_MEMORY.
  subroutine sweep_order(mesh, sw, st)
    type(mesh_t), intent(in) :: mesh
    type(p2_sweeper_t), intent(inout) :: sw
    type(status_t), intent(inout) :: st
    integer, allocatable :: zof(:)
    integer :: t, l, i, n, ist, cl(6)
    allocate (zof(sw%n2), sw%order(sw%nz), stat=ist)
    if (alloc_failed(ist, st, 'the order of the sweeps', int(sw%n2, i8) + sw%nz, BYTES_INT)) return
    zof = 0
    do i = 1, sw%nz
      zof(node_carrying(sw, i)) = i
    end do
    n = 0
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      do l = 1, 6
        i = zof(cl(l))
        if (i == 0) cycle
        n = n + 1
        sw%order(n) = i
        zof(cl(l)) = 0                    ! reached
      end do
    end do
  end subroutine sweep_order

  !> The triangles at every P2 node (p2_sweeper_t%at_ptr, at).
  subroutine node_triangles(mesh, n2, at_ptr, at, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: n2
    integer, allocatable, intent(out) :: at_ptr(:), at(:)
    type(status_t), intent(inout) :: st
    integer :: t, l, p, ist
    integer :: cl(6)
    allocate (at_ptr(n2 + 1), at(6 * mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the triangles at the P2 nodes', n2 + 1 + 6_i8 * mesh%ntri, BYTES_INT)) return
    at_ptr = 0
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      at_ptr(cl + 1) = at_ptr(cl + 1) + 1
    end do
    at_ptr(1) = 1
    do p = 1, n2
      at_ptr(p + 1) = at_ptr(p + 1) + at_ptr(p)
    end do
    do t = 1, mesh%ntri                    ! at_ptr(p) runs ahead while filling, then is moved back
      cl = p2_dofs(mesh, t)
      do l = 1, 6
        at(at_ptr(cl(l))) = ishft(t - 1, local_bits) + l - 1
        at_ptr(cl(l)) = at_ptr(cl(l)) + 1
      end do
    end do
    do p = n2, 1, -1
      at_ptr(p + 1) = at_ptr(p)
    end do
    at_ptr(1) = 1
  end subroutine node_triangles

  !> diag(i) = (R^T K R)_ii = sum over the nodes p, q of column i of R, R_pi K_pq R_qi, from
  !> the triangles at p.  A column with one entry 1 (every unknown off the active Gamma_a
  !> rows) takes K_pp.
  subroutine reduced_diagonal(mesh, rmat, sw)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(in) :: rmat
    type(p2_sweeper_t), intent(inout) :: sw
    real(dp) :: ke(6, 6), acc, rq
    integer :: i, c, p, k, t, l, m, q, r, cl(6)
    do i = 1, sw%nz
      acc = 0.0_dp
      if (sw%zcode(i) > 0) then
        p = sw%zcode(i)                     ! R e_i is the unit vector of node p: K_pp
        do k = sw%at_ptr(p), sw%at_ptr(p + 1) - 1
          t = ishft(sw%at(k), -local_bits) + 1
          l = iand(sw%at(k), 7) + 1
          if (sw%classes) then
            acc = acc + sw%ke(l, l, sw%cls(t))
          else
            call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
            acc = acc + ke(l, l)
          end if
        end do
        sw%diag(i) = acc
        cycle
      end if
      associate (kk => -sw%zcode(i))
        do c = sw%spec_ptr(kk), sw%spec_ptr(kk + 1) - 1
          p = sw%spec_p(c)
          do k = sw%at_ptr(p), sw%at_ptr(p + 1) - 1
            t = ishft(sw%at(k), -local_bits) + 1
            l = iand(sw%at(k), 7) + 1
            call element_matrix(mesh, sw, t, ke)
            cl = p2_dofs(mesh, t)
            do m = 1, 6
              q = cl(m)
              rq = 0.0_dp
              do r = rmat%rowptr(q), rmat%rowptr(q + 1) - 1
                if (rmat%col(r) == i) rq = rmat%val(r)
              end do
              acc = acc + sw%spec_w(c) * ke(l, m) * rq
            end do
          end do
        end do
      end associate
      sw%diag(i) = acc
    end do
  end subroutine reduced_diagonal

  !> The node that carries unknown i (R is 1 there).
  pure integer function node_carrying(sw, i) result(p)
    type(p2_sweeper_t), intent(in) :: sw
    integer, intent(in) :: i
    p = sw%zcode(i)
    if (p < 0) p = sw%spec_node(-p)
  end function node_carrying

  !> One Gauss-Seidel sweep on R^T K R z + shift diag(R^T K R) z = R^T F in the unknowns z,
  !> forward (in sw%order) or backward, done on psi = R z (module header).  fz = R^T F.
  !> decrease: the decrease of J(z) = z^T (R^T K R (1 + shift)) z / 2 - fz^T z the sweep
  !> made, sum of s_i^2 / (2 a_ii) over its steps (s_i the residual of row i when visited).
  subroutine p2_sweep(mesh, sw, fz, shift, psi, forward, decrease)
    type(mesh_t), intent(in) :: mesh
    type(p2_sweeper_t), intent(in) :: sw
    real(dp), intent(in) :: fz(:)
    real(dp), intent(in) :: shift
    real(dp), intent(inout) :: psi(:)
    logical, intent(in) :: forward
    real(dp), intent(out) :: decrease
    real(dp) :: s, d, a, dj
    integer :: i, j, i0, i1, di, c, k
    if (forward) then
      i0 = 1
      i1 = sw%nz
      di = 1
    else
      i0 = sw%nz
      i1 = 1
      di = -1
    end if
    if (sw%classes) then
      call sweep_classes(sw%nz, sw%n2, mesh%ntri, size(sw%ke, 3), mesh%nnode, i0, i1, di, sw%order, sw%diag, &
                         sw%zcode, sw%spec_node, sw%spec_ptr, sw%spec_p, sw%spec_w, sw%at_ptr, sw%at, mesh%tri, &
                         mesh%tri_edge, sw%cls, sw%ke, fz, shift, psi, decrease)
      return
    end if
    dj = 0.0_dp
    do j = i0, i1, di
      i = sw%order(j)
      a = sw%diag(i) * (1.0_dp + shift)
      if (.not. a > 0.0_dp) cycle
      s = fz(i) - shift * sw%diag(i) * psi(node_carrying(sw, i))
      if (sw%zcode(i) > 0) then
        s = s - k_row_times(mesh, sw, sw%zcode(i), psi)
        d = s / a
        psi(sw%zcode(i)) = psi(sw%zcode(i)) + d
      else
        k = -sw%zcode(i)
        do c = sw%spec_ptr(k), sw%spec_ptr(k + 1) - 1
          s = s - sw%spec_w(c) * k_row_times(mesh, sw, sw%spec_p(c), psi)
        end do
        d = s / a
        do c = sw%spec_ptr(k), sw%spec_ptr(k + 1) - 1
          psi(sw%spec_p(c)) = psi(sw%spec_p(c)) + sw%spec_w(c) * d
        end do
      end if
      dj = dj + s * d
    end do
    decrease = 0.5_dp * dj
  end subroutine p2_sweep

  !> p2_sweep with the element matrices of the shape classes, on explicit-shape arrays (so
  !> that the compiler sees contiguous data: 1.5 times faster than through the derived
  !> types' descriptors at level 9 of p2_contact).  Arguments: those of p2_sweeper_t, the
  !> mesh's tri and tri_edge, the visiting range i0:i1:di of order.
  pure subroutine sweep_classes(nz, n2, ntri, nshape, nnode, i0, i1, di, order, diag, zcode, spec_node, spec_ptr, &
                                spec_p, spec_w, at_ptr, at, tri, tri_edge, cls, ke, fz, shift, psi, decrease)
    integer, intent(in) :: nz, n2, ntri, nshape, nnode, i0, i1, di
    integer, intent(in) :: order(nz), zcode(nz), spec_node(*), spec_ptr(*), spec_p(*), at_ptr(n2 + 1), at(6 * ntri)
    integer, intent(in) :: tri(3, ntri), tri_edge(3, ntri), cls(ntri)
    real(dp), intent(in) :: diag(nz), spec_w(*), ke(6, 6, nshape), fz(nz), shift
    real(dp), intent(inout) :: psi(n2)
    real(dp), intent(out) :: decrease
    real(dp) :: s, d, a, dj
    integer :: i, j, c, p, k
    dj = 0.0_dp
    do j = i0, i1, di
      i = order(j)
      a = diag(i) * (1.0_dp + shift)
      if (.not. a > 0.0_dp) cycle
      p = zcode(i)
      if (p > 0) then                        ! column i of R: the unit vector of node p
        s = fz(i) - shift * diag(i) * psi(p) - k_row(p)
        d = s / a
        psi(p) = psi(p) + d
      else
        k = -p
        s = fz(i) - shift * diag(i) * psi(spec_node(k))
        do c = spec_ptr(k), spec_ptr(k + 1) - 1
          s = s - spec_w(c) * k_row(spec_p(c))
        end do
        d = s / a
        do c = spec_ptr(k), spec_ptr(k + 1) - 1
          psi(spec_p(c)) = psi(spec_p(c)) + spec_w(c) * d
        end do
      end if
      dj = dj + s * d
    end do
    decrease = 0.5_dp * dj
  contains
    !> (K psi)_q from the triangles at node q (K symmetric: column l of a class's matrix is row l).
    pure real(dp) function k_row(q) result(acc)
      integer, intent(in) :: q
      integer :: m, t, l, c0
      acc = 0.0_dp
      do m = at_ptr(q), at_ptr(q + 1) - 1
        t = ishft(at(m), -local_bits) + 1
        l = iand(at(m), 7) + 1
        c0 = cls(t)
        acc = acc + ke(1, l, c0) * psi(tri(1, t)) + ke(2, l, c0) * psi(tri(2, t)) &
                  + ke(3, l, c0) * psi(tri(3, t)) + ke(4, l, c0) * psi(nnode + tri_edge(1, t)) &
                  + ke(5, l, c0) * psi(nnode + tri_edge(2, t)) + ke(6, l, c0) * psi(nnode + tri_edge(3, t))
      end do
    end function k_row
  end subroutine sweep_classes

  !> (K psi)_p from the triangles at node p.
  pure real(dp) function k_row_times(mesh, sw, p, psi) result(acc)
    type(mesh_t), intent(in) :: mesh
    type(p2_sweeper_t), intent(in) :: sw
    integer, intent(in) :: p
    real(dp), intent(in) :: psi(:)
    real(dp) :: ke(6, 6)
    integer :: k, t, l, m, cl(6)
    acc = 0.0_dp
    do k = sw%at_ptr(p), sw%at_ptr(p + 1) - 1
      t = ishft(sw%at(k), -local_bits) + 1
      l = iand(sw%at(k), 7) + 1
      cl(1:3) = mesh%tri(:, t)               ! p2_dofs, written out: this is the sweep's inner loop
      cl(4:6) = mesh%nnode + mesh%tri_edge(:, t)
      if (sw%classes) then
        associate (kc => sw%ke(:, l, sw%cls(t)))     ! K symmetric: column l is row l
          do m = 1, 6
            acc = acc + kc(m) * psi(cl(m))
          end do
        end associate
      else
        call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
        do m = 1, 6
          acc = acc + ke(m, l) * psi(cl(m))
        end do
      end if
    end do
  end function k_row_times

  !> The element matrix of triangle t: its class's, or computed.
  pure subroutine element_matrix(mesh, sw, t, ke)
    type(mesh_t), intent(in) :: mesh
    type(p2_sweeper_t), intent(in) :: sw
    integer, intent(in) :: t
    real(dp), intent(out) :: ke(6, 6)
    if (sw%classes) then
      ke = sw%ke(:, :, sw%cls(t))
    else
      call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
    end if
  end subroutine element_matrix
end module dualsig_dual_p2_sweeps
