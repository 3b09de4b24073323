!> Exact equilibration of a P2 dual flux by a spanning forest of the dual graph.
!>
!> Why this is legitimate.  The bound (6.26) holds for ANY admissible lambda^h, not only for
!> the exact minimiser of (4.5): it only needs div lambda^h = -f and lambda^h . nu >= 0 on
!> Gamma_a.  A solver returns q^h with a small divergence defect D x /= 0 (the rounding of a
!> large penalised solve for the augmented Lagrangian, the unfinished iteration for plain
!> Uzawa).  This module moves x into ker D by adding constant normal fluxes on a set of
!> edges, never on Gamma_a, so the bounds x >= g_h keep holding and the corrected field is
!> admissible to rounding.  The correction is of the size of the solver's defect: for the
!> fast solver it changes the field at rounding level only; for plain Uzawa, whose averaged
!> iterate has a real defect, it makes the output admissible, so that its bound is
!> guaranteed too (how sharp it is still depends on how close the iterate was to the
!> minimiser).
!>
!> Conventions (those of dualsig_assembly_equilibrium).  Global unknown 2 (e - 1) + j is
!> q . n_e at end node j of edge e, n_e the outward normal of T1 = edge_tri(1, e); the
!> element parameters are beta(k, t) = sgn(k, t) x(dof(k, t)), sgn = +1 in T1 and -1 in the
!> neighbour, so beta is always the flux through the OUTWARD normal of t.  The divergence
!> row of t is w_t = sum_k d(k, t) beta(k, t) (d from equilibrium_elements: half the side
!> lengths), i.e. the outward flux of q through the boundary of t, = int_t div q.
!>
!> Adding alpha to both unknowns of edge e (a constant normal flux alpha n_e along e)
!> changes w_t of each adjacent triangle t by alpha gamma(e, t), with
!>     gamma(e, t) = sum over the two local k with dof(k, t) in {2e-1, 2e} of d(k, t) sgn(k, t)
!> = +l_e in T1 (the flux leaves T1) and -l_e in the neighbour (it enters there); the two
!> are opposite, so the total divergence is conserved and only moved along e.
!>
!> Algorithm.  A spanning forest of the dual graph: its roots are the triangles with a
!> Gamma_u boundary edge (parent edge: that edge, which touches no other triangle), then
!> breadth-first search across interior edges; Gamma_a edges are never used.  In reverse
!> BFS order (children before parents) w_t is recomputed from the current x and
!> alpha = -w_t / gamma(parent edge, t) is added to both unknowns of the parent edge: this
!> zeroes w_t and moves the defect to the parent (processed later), or, at a root, out
!> through Gamma_u, where the flux is free.  A later step changes the parent edge of a
!> triangle u earlier in BFS order, which touches only u and its parent, both earlier than
!> t: no edge of t changes after t's step, so at the end every w_t is zero to rounding.
!> O(ntri) work and memory.
!>
!> Every triangle is reached when every connected component of the mesh has a Gamma_u edge
!> (which (A2) implies for a connected mesh); otherwise an error names a triangle that is
!> not reached and x is unchanged.
module dualsig_equilibrium_correction
  use dualsig_kinds, only: dp
  use dualsig_mesh, only: mesh_t
  use dualsig_assembly_equilibrium, only: equilibrium_map_t
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT, DS_ERR_NUMERIC
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  implicit none
  private

  public :: equilibrate_divergence, edge_divergence_weight

contains

  !> gamma(e, t): the change of w_t = sum_k d(k, t) beta(k, t) per unit constant normal flux
  !> alpha n_e added on edge e (alpha on both unknowns 2e-1, 2e).  +l_e when t is
  !> edge_tri(1, e), -l_e in the neighbour; 0 if e is not an edge of t.
  pure real(dp) function edge_divergence_weight(map, d, e, t) result(g)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    integer, intent(in) :: e, t
    integer :: k
    g = 0.0_dp
    do k = 1, 6
      if ((map%dof(k, t) + 1) / 2 == e) g = g + d(k, t) * map%sgn(k, t)
    end do
  end function edge_divergence_weight

  !> Change x (global edge-end fluxes, 2 nedge) so that every triangle's divergence row
  !> w_t = sum_k d(k, t) sgn(k, t) x(dof(k, t)) vanishes to rounding -- or, with target,
  !> equals target(t) (the outward flux int_t div q wanted) -- by constant normal fluxes on
  !> Gamma_u and interior edges of a spanning forest of the dual graph.  The unknowns of
  !> Gamma_a edges (is_gamma_a, per boundary edge) are not changed.
  !> On an error x is unchanged.
  subroutine equilibrate_divergence(mesh, map, d, is_gamma_a, x, st, target)
    type(mesh_t), intent(in) :: mesh
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    logical, intent(in) :: is_gamma_a(:)
    real(dp), intent(inout) :: x(:)
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: target(:)   !! (ntri) wanted w_t (default 0)
    integer, allocatable :: order(:), parent_edge(:)
    integer :: j, e, t, s, nb, head, tail, i, ist
    real(dp) :: w, g, alpha

    if (map%ntri /= mesh%ntri .or. map%nedge /= mesh%nedge) then
      call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: the equilibrium map is not of this mesh')
      return
    end if
    if (size(d, 1) /= 6 .or. size(d, 2) /= mesh%ntri) then
      call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: d must be (6, ntri) = (6, ' // &
        itoa(mesh%ntri) // ')')
      return
    end if
    if (size(is_gamma_a) /= mesh%nbedge) then
      call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: is_gamma_a has ' // itoa(size(is_gamma_a)) // &
        ' entries, expected one per boundary edge (' // itoa(mesh%nbedge) // ')')
      return
    end if
    if (size(x) /= 2 * mesh%nedge) then
      call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: x has ' // itoa(size(x)) // &
        ' entries, expected 2 nedge = ' // itoa(2 * mesh%nedge))
      return
    end if

    ! spanning forest: parent_edge(t) = 0 while t is not reached; order = BFS order
    allocate (order(mesh%ntri), parent_edge(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the spanning forest of the triangles', 2 * mesh%ntri, BYTES_INT)) return
    order = 0
    parent_edge = 0
    tail = 0
    do j = 1, mesh%nbedge
      if (is_gamma_a(j)) cycle
      e = mesh%bedge_edge(j)
      t = mesh%edge_tri(1, e)
      if (parent_edge(t) /= 0) cycle
      parent_edge(t) = e
      tail = tail + 1
      order(tail) = t
    end do
    head = 0
    do while (head < tail)
      head = head + 1
      t = order(head)
      do s = 1, 3
        e = mesh%tri_edge(s, t)
        if (mesh%edge_tri(2, e) == 0) cycle          ! boundary edge: Gamma_u only as a root's parent
        nb = merge(mesh%edge_tri(2, e), mesh%edge_tri(1, e), mesh%edge_tri(1, e) == t)
        if (parent_edge(nb) /= 0) cycle
        parent_edge(nb) = e
        tail = tail + 1
        order(tail) = nb
      end do
    end do
    if (tail < mesh%ntri) then
      t = findloc(parent_edge, 0, dim=1)
      call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: triangle ' // itoa(t) // &
        ' is not connected to any Gamma_u edge across interior edges (' // itoa(mesh%ntri - tail) // &
        ' triangles unreached); its divergence cannot be equilibrated without changing Gamma_a fluxes' // &
        ' (assumption (A2): every boundary loop meets Gamma_u)')
      return
    end if
    do t = 1, mesh%ntri                        ! (in memory order: any order will do)
      if (edge_divergence_weight(map, d, parent_edge(t), t) == 0.0_dp) then
        call set_error(st, DS_ERR_NUMERIC, 'equilibrate_divergence: triangle ' // itoa(t) // &
          ' has a zero divergence weight on its edge ' // itoa(parent_edge(t)) // ' (degenerate side)')
        return
      end if
    end do

    if (present(target)) then
      if (size(target) /= mesh%ntri) then
        call set_error(st, DS_ERR_INPUT, 'equilibrate_divergence: target has ' // itoa(size(target)) // &
          ' entries, expected one per triangle (' // itoa(mesh%ntri) // ')')
        return
      end if
    end if
    ! children before parents: w_t - target_t to zero by the constant flux alpha on the parent edge
    do i = mesh%ntri, 1, -1
      t = order(i)
      e = parent_edge(t)
      w = sum(d(:, t) * map%sgn(:, t) * x(map%dof(:, t)))
      if (present(target)) w = w - target(t)
      g = edge_divergence_weight(map, d, e, t)
      alpha = -w / g
      x(2 * e - 1) = x(2 * e - 1) + alpha
      x(2 * e) = x(2 * e) + alpha
    end do
  end subroutine equilibrate_divergence
end module dualsig_equilibrium_correction
