!> The primal problems P1 and P2 discretised by continuous P1 elements (Section 2):
!> the matrix, the load vector, the convex set K_ih as bounds per node, and the solve.
!>
!>   P1: A = K + M (A_ij = (phi_i, phi_j)_1), v_j >= 0 at every boundary node.
!>   P2: A = K,  v_j = 0 at nodes on the closure of Gamma_u, v_j >= 0 at the other nodes
!>       of Gamma_a (the reading notes correct the print, which says Gamma_u twice).
module dualsig_problem_primal
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_sparse, only: csr_t
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_assembly_p1, only: assemble_p1_operator, assemble_load
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_strings, only: itoa
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  ! PROBLEM_* live in dualsig_problem_kinds; re-exported for existing callers
  public :: primal_system_t, primal_constraints, primal_assemble, PROBLEM_P1, PROBLEM_P2


  type :: primal_system_t
    integer :: problem = PROBLEM_P2
    type(csr_t) :: a                     !! K + M (P1) or K (P2)
    real(dp), allocatable :: load(:)     !! F_j = (f, phi_j)_0
    integer, allocatable :: kind(:)      !! BOUND_FREE / BOUND_LOWER / BOUND_FIXED per node
    real(dp), allocatable :: bnd(:)      !! bound value per node (0 for K_1h, K_2h)
  end type primal_system_t

contains

  !> Bounds per node describing K_1h (P1) or K_2h (P2).  `gamma_u` and `gamma_a` list the
  !> boundary markers of the two parts (zeros are unused slots).  Every marker present
  !> on the mesh must be named exactly once; for P2, Gamma_u must contain an edge
  !> (coercivity); for P1, Gamma_u must be empty.  With `every_loop_gamma_u` (optional,
  !> default .false.; the P2 equilibrium dual needs it) every boundary loop must contain a
  !> Gamma_u edge: the paper's assumption (A2).  (A3), the end points of Gamma_a are mesh
  !> vertices, holds by construction: the parts are unions of marked boundary edges.
  subroutine primal_constraints(mesh, problem, gamma_u, gamma_a, kind, bnd, st, every_loop_gamma_u)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: problem
    integer, intent(in) :: gamma_u(:), gamma_a(:)
    integer, allocatable, intent(out) :: kind(:)
    real(dp), allocatable, intent(out) :: bnd(:)
    type(status_t), intent(out) :: st
    logical, intent(in), optional :: every_loop_gamma_u
    integer :: j, m, nu, l, ist
    character(len=200) :: buf

    allocate (kind(mesh%nnode), bnd(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the primal bounds', 3 * mesh%nnode, BYTES_INT)) return
    kind = BOUND_FREE
    bnd = 0.0_dp
    do j = 1, size(gamma_u)
      if (gamma_u(j) /= 0 .and. any(gamma_a == gamma_u(j))) then
        write (buf, '(a,i0,a)') 'boundary marker ', gamma_u(j), ' is listed in both Gamma_u and Gamma_a ' // &
          '(expected in &run gamma_u_markers or gamma_a_markers, not both)'
        call set_error(st, DS_ERR_INPUT, trim(buf))
        return
      end if
    end do
    do j = 1, size(gamma_u)
      if (gamma_u(j) > 0 .and. .not. any(mesh%bedge_marker == gamma_u(j))) then
        call set_error(st, DS_ERR_INPUT, '&run gamma_u_markers: marker ' // itoa(gamma_u(j)) // &
          ' does not occur on the mesh boundary (expected markers of the mesh: ' // marker_list() // ')')
        return
      end if
    end do
    do j = 1, size(gamma_a)
      if (gamma_a(j) > 0 .and. .not. any(mesh%bedge_marker == gamma_a(j))) then
        call set_error(st, DS_ERR_INPUT, '&run gamma_a_markers: marker ' // itoa(gamma_a(j)) // &
          ' does not occur on the mesh boundary (expected markers of the mesh: ' // marker_list() // ')')
        return
      end if
    end do
    nu = 0
    do j = 1, mesh%nbedge
      m = mesh%bedge_marker(j)
      if (any(gamma_u == m)) then
        nu = nu + 1
      else if (.not. any(gamma_a == m)) then
        write (buf, '(a,i0,a,i0,a)') 'boundary marker ', m, ' (boundary edge ', j, &
          ') is named neither in Gamma_u nor in Gamma_a (expected every marker of the mesh in ' // &
          '&run gamma_u_markers or gamma_a_markers)'
        call set_error(st, DS_ERR_INPUT, trim(buf))
        return
      end if
    end do
    if (problem == PROBLEM_P1 .and. nu > 0) then
      call set_error(st, DS_ERR_INPUT, 'problem P1 has Signorini conditions on all of Gamma: ' // &
                     'Gamma_u must be empty')
      return
    end if
    if (problem == PROBLEM_P2 .and. nu == 0) then
      call set_error(st, DS_ERR_INPUT, 'problem P2 needs a non-empty Gamma_u (u = 0 there)')
      return
    end if
    if (present(every_loop_gamma_u)) then
      if (every_loop_gamma_u) then
        do l = 1, mesh%nloop
          if (.not. any([(any(gamma_u == mesh%bedge_marker(mesh%loop_bedge(j))), &
                          j = mesh%loop_start(l), mesh%loop_start(l + 1) - 1)])) then
            call set_error(st, DS_ERR_INPUT, 'boundary loop ' // itoa(l) // ' (' // &
              itoa(mesh%loop_start(l + 1) - mesh%loop_start(l)) // ' edges, markers ' // marker_list(l) // &
              ') has no Gamma_u edge; the P2 dual analysis needs (A2): every boundary loop meets Gamma_u ' // &
              '(expected one of its markers in &run gamma_u_markers)')
            return
          end if
        end do
      end if
    end if
    ! Signorini nodes first, then the closure of Gamma_u overrides them with u = 0.
    do j = 1, mesh%nbedge
      if (.not. any(gamma_u == mesh%bedge_marker(j))) kind(mesh%bedge_nodes(:, j)) = BOUND_LOWER
    end do
    do j = 1, mesh%nbedge
      if (any(gamma_u == mesh%bedge_marker(j))) kind(mesh%bedge_nodes(:, j)) = BOUND_FIXED
    end do

  contains

    !> The distinct boundary markers of the mesh (of boundary loop `loop` only, if given),
    !> ascending, separated by blanks.
    function marker_list(loop) result(s)
      integer, intent(in), optional :: loop
      character(len=:), allocatable :: s
      integer, allocatable :: marks(:)
      integer :: k, lo, hi, prev, next
      lo = 1
      hi = mesh%nbedge
      if (present(loop)) then
        lo = mesh%loop_start(loop)
        hi = mesh%loop_start(loop + 1) - 1
        marks = mesh%bedge_marker(mesh%loop_bedge(lo:hi))
      else
        marks = mesh%bedge_marker(lo:hi)
      end if
      s = ''
      prev = 0
      do k = 1, size(marks)                      ! markers are > 0: ascending by repeated minimum
        if (.not. any(marks > prev)) exit
        next = minval(marks, mask=marks > prev)
        s = s // ' ' // itoa(next)
        prev = next
      end do
      s = adjustl(s)
      s = trim(s)
    end function marker_list
  end subroutine primal_constraints

  !> Matrix and load vector of the primal problem: A = K + M for P1, K for P2 (no mass
  !> matrix), F_j = (f, phi_j)_0 with the quadrature `rule`.  Out of memory:
  !> DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine primal_assemble(mesh, problem, f, rule, sys, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: problem
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(primal_system_t), intent(inout) :: sys
    type(status_t), intent(out) :: st
    integer :: ist
    sys%problem = problem
    call assemble_p1_operator(mesh, merge(1.0_dp, 0.0_dp, problem == PROBLEM_P1), sys%a, st)
    if (has_failed(st)) return
    if (allocated(sys%load)) deallocate (sys%load)
    allocate (sys%load(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the primal load vector', mesh%nnode, BYTES_REAL)) return
    call assemble_load(mesh, f, rule, sys%load)
  end subroutine primal_assemble
end module dualsig_problem_primal
