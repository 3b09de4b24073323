!> Uniform ("red") refinement of a triangular mesh and the matching P1 prolongation.
!>
!> Numbering of the refined mesh produced by `mesh_refine_uniform` (relied upon by
!> `mesh_prolongate_p1` and by any caller that transfers data between the levels):
!> - nodes 1..nnode are the coarse nodes, with the same coordinates;
!> - node nnode + e is the midpoint of coarse edge e (`coarse%edge_nodes(:,e)`);
!> - the children of coarse triangle t are fine triangles 4t-3 .. 4t.  With the coarse
!>   vertices v1, v2, v3 and the midpoints m1, m2, m3 of local edges 1, 2, 3 (sides
!>   v1v2, v2v3, v3v1) they are, all counter-clockwise:
!>     4t-3 = (v1, m1, m3),  4t-2 = (m1, v2, m2),  4t-1 = (m3, m2, v3),  4t = (m1, m2, m3);
!>   each child has the region (`tri_region`) of its parent, when the coarse mesh has regions;
!> - coarse boundary edge j (a -> b, midpoint m) becomes fine boundary edges 2j-1 = (a, m)
!>   and 2j = (m, b), both with the marker of j.
!> Every child is similar to its parent, so angles (and the alpha-beta regularity of the
!> family) are preserved and h halves.
module dualsig_mesh_refine
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, DS_ERR_MESH
  use dualsig_mesh, only: mesh_t, mesh_build_topology
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: mesh_refine_uniform, mesh_prolongate_p1

contains

  !> Red refinement: every triangle of `coarse` split into four by its edge midpoints.
  !> `coarse` must carry its topology (mesh_build_topology); `fine` gets its own.
  !> Runs in time linear in the size of the coarse mesh.
  subroutine mesh_refine_uniform(coarse, fine, st)
    type(mesh_t), intent(in) :: coarse
    type(mesh_t), intent(out) :: fine
    type(status_t), intent(out) :: st
    integer :: nn, t, e, j, v(3), m(3), ist

    if (coarse%ntri < 1 .or. .not. (allocated(coarse%tri_edge) .and. allocated(coarse%edge_nodes) &
        .and. allocated(coarse%bedge_edge))) then
      call set_error(st, DS_ERR_MESH, 'mesh_refine_uniform: the coarse mesh has no topology ' // &
        '(expected a mesh with triangles, finished by mesh_build_topology)')
      return
    end if
    nn = coarse%nnode
    fine%nnode = nn + coarse%nedge
    fine%ntri = 4 * coarse%ntri
    fine%nbedge = 2 * coarse%nbedge
    allocate (fine%xy(2, fine%nnode), fine%tri(3, fine%ntri), fine%bedge_nodes(2, fine%nbedge), &
              fine%bedge_marker(fine%nbedge), stat=ist)
    if (alloc_failed(ist, st, 'the refined mesh', 2_i8 * fine%nnode + fine%ntri + fine%nbedge, BYTES_REAL)) return

    fine%xy(:, 1:nn) = coarse%xy(:, 1:nn)
    do e = 1, coarse%nedge
      fine%xy(:, nn + e) = 0.5_dp * (coarse%xy(:, coarse%edge_nodes(1, e)) + &
                                     coarse%xy(:, coarse%edge_nodes(2, e)))
    end do

    do t = 1, coarse%ntri
      v = coarse%tri(:, t)
      m = nn + coarse%tri_edge(:, t)
      fine%tri(:, 4 * t - 3) = [v(1), m(1), m(3)]
      fine%tri(:, 4 * t - 2) = [m(1), v(2), m(2)]
      fine%tri(:, 4 * t - 1) = [m(3), m(2), v(3)]
      fine%tri(:, 4 * t) = [m(1), m(2), m(3)]
    end do

    if (allocated(coarse%tri_region)) then
      allocate (fine%tri_region(fine%ntri), stat=ist)
      if (alloc_failed(ist, st, 'the regions of the refined mesh', fine%ntri, BYTES_INT)) return
      do t = 1, coarse%ntri
        fine%tri_region(4 * t - 3:4 * t) = coarse%tri_region(t)
      end do
    end if

    do j = 1, coarse%nbedge
      e = nn + coarse%bedge_edge(j)
      fine%bedge_nodes(:, 2 * j - 1) = [coarse%bedge_nodes(1, j), e]
      fine%bedge_nodes(:, 2 * j) = [e, coarse%bedge_nodes(2, j)]
      fine%bedge_marker(2 * j - 1:2 * j) = coarse%bedge_marker(j)
    end do

    call mesh_build_topology(fine, st)
    if (st%code /= 0) st%msg = 'mesh_refine_uniform: ' // st%msg   ! keep the code, name the source
  end subroutine mesh_refine_uniform

  !> Interpolate a continuous P1 nodal vector from `coarse` to the mesh `fine` obtained
  !> from it by mesh_refine_uniform: coarse nodal values are copied, the value at the
  !> midpoint node nnode+e is the mean of the values at the two ends of coarse edge e.
  !> Exact for functions that are linear on each coarse triangle.  This relies on the node
  !> numbering of mesh_refine_uniform (see the module header); sizes: uc(coarse%nnode),
  !> uf(fine%nnode) with fine%nnode = coarse%nnode + coarse%nedge.
  pure subroutine mesh_prolongate_p1(coarse, fine, uc, uf)
    type(mesh_t), intent(in) :: coarse
    type(mesh_t), intent(in) :: fine
    real(dp), intent(in) :: uc(coarse%nnode)
    real(dp), intent(out) :: uf(fine%nnode)
    integer :: nn, e
    nn = coarse%nnode
    uf(1:nn) = uc
    do e = 1, coarse%nedge
      uf(nn + e) = 0.5_dp * (uc(coarse%edge_nodes(1, e)) + uc(coarse%edge_nodes(2, e)))
    end do
  end subroutine mesh_prolongate_p1
end module dualsig_mesh_refine
