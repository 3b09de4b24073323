!> The module side of the F77 entry point DSSIGN (dualsig_f77.f90): the checks of its
!> arguments in their order, the mesh built from them, the option slots IOPT/ROPT read
!> into analysis settings, and one level of the analysis pipeline (dualsig_analysis)
!> mapped back onto U, Q, BOUNDS and INFO.  The INFO values are documented at DSSIGN.
!>
!> Nothing here stops the host program; messages are printed only when IOPT(4) asks for
!> them, on the unit IOPT(5) (default: standard output).
module dualsig_f77_adapter
  use, intrinsic :: iso_fortran_env, only: output_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, is_ok, DS_OK
  use dualsig_strings, only: itoa, rtoa
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_mesh, only: mesh_t, mesh_build_topology, mesh_triangle_area, mesh_move, mesh_zero_area, &
                          mesh_coordinate_scale
  use dualsig_mesh_check, only: mesh_orient_triangles, mesh_check_duplicates, mesh_check_geometry
  use dualsig_sparse_direct, only: ORDERING_BEST, ORDERING_AMD, ORDERING_METIS, ORDERING_NATURAL, ORDERING_GEOMETRIC
  use dualsig_fields, only: scalar_field, function_field
  use dualsig_dual_p2_field, only: dual_p2_lambda
  use dualsig_assembly_dual_hdiv, only: hdiv_point_value
  use dualsig_problem_dual_p2, only: dual_p2_check_assumptions
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, level_result_t, analysis_t, &
                              analysis_start, analysis_next_level
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  use dualsig_sparse, only: csr_t
  use dualsig_spectral, only: jacobi_scaled_extremes
  implicit none
  private

  public :: dssign_run
  public :: f77_transpose_csr, f77_no_negative_curvature
  public :: info_primal_limit, info_dual_limit, info_not_admissible, info_failed

  ! Defaults of the option slots (the driver's defaults, dualsig_io_config).
  integer, parameter :: default_primal_method = 2         !! IOPT(1): active set
  integer, parameter :: default_max_iter = 200000         !! IOPT(2)
  integer, parameter :: default_dual_max_iter = 20000     !! IOPT(7)
  integer, parameter :: default_check_every = 10          !! IOPT(8)
  real(dp), parameter :: default_tol = 1.0e-10_dp         !! ROPT(1)
  real(dp), parameter :: default_omega = 1.0_dp           !! ROPT(2)
  real(dp), parameter :: default_dual_tol = 1.0e-10_dp    !! ROPT(3)
  real(dp), parameter :: default_dual_tol_h2 = 1.0e-4_dp  !! ROPT(4)
  real(dp), parameter :: default_admissible = 1.0e-10_dp  !! ROPT(7), as dualsig_analysis
  integer, parameter :: dual_off = 3                      !! IOPT(3) value: no dual analysis
  integer, parameter :: p1_space_paper = 2                !! IOPT(10) value: the paper's P1 dual space
  !> Break lines DSSIGNB accepts at most.
  integer, parameter :: max_breaks = 16
  ! Boundary markers of IBMARK.
  integer, parameter :: mark_gamma_u = 1, mark_gamma_a = 2
  !> `arg` of the mesh checks when they ran out of memory (INFO = info_failed, not -arg).
  integer, parameter :: arg_no_memory = -1
  ! INFO values > 0.
  integer, parameter :: info_primal_limit = 1, info_dual_limit = 2, info_not_admissible = 4, &
                        info_failed = 8

  !> The options of IOPT/ROPT, defaults filled in.
  type :: dssign_options_t
    integer :: verbosity = 0                 !! IOPT(4): 0 silent, 1 messages, 2 solver reports
    integer :: out = output_unit             !! IOPT(5): unit of the messages
    integer :: primal_method = default_primal_method
    integer :: max_iter = default_max_iter
    integer :: dual_method = 0               !! IOPT(3): 0/1 default, 2 uzawa, 3 none
    integer :: ordering = ORDERING_AMD
    integer :: dual_max_iter = default_dual_max_iter
    integer :: check_every = default_check_every
    logical :: start_from_u = .false.        !! IOPT(9) = 1
    integer :: p1_space = 0                  !! IOPT(10): P1 dual space, 0/1 RT1 (H(div)), 2 the paper's
    real(dp) :: tol = default_tol, omega = default_omega, dual_tol = default_dual_tol
    real(dp) :: dual_tol_h2 = default_dual_tol_h2, rho = 0.0_dp, penalty = 0.0_dp
    real(dp) :: admissible = default_admissible
  end type dssign_options_t

  !> The sides of the (reoriented) triangles: side p = (lo, hi(p)) lives in bucket lo, slots
  !> head(lo) .. head(lo)+fill(lo)-1; count(p) triangles share it; from(:, p) is the side as
  !> it runs in its first triangle (counter-clockwise, so a boundary side has the domain on
  !> its left).  nbside counts the sides with one triangle.
  type :: side_table_t
    integer, allocatable :: head(:), fill(:), hi(:), count(:), from(:,:)
    integer :: nbside = 0
  end type side_table_t

  !> DSBQP's definiteness check (f77_no_negative_curvature): Lanczos steps on
  !> D^(-1/2) A D^(-1/2) at most, and the smallest Ritz value below -indefinite_rel_tol times
  !> the largest that proves A indefinite (Ritz values lie in the spectrum).
  integer, parameter :: definiteness_steps = 60
  real(dp), parameter :: indefinite_rel_tol = 1.0e-8_dp

contains

  !> DSSIGN (and, with nbreak/xbreak, DSSIGNB): the arguments checked in order, INFO = -k
  !> for the first bad one (k counted in DSSIGN's argument list; DSSIGNB's NBREAK and
  !> XBREAK are 10 and 11 and shift the later ones by two), then one level of the analysis.
  subroutine dssign_run(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, fsrc, iopt, ropt, u, q, bounds, info, &
                        nbreak, xbreak)
    integer, intent(in) :: iprob, nnode, ntri, nbedge
    real(dp), intent(in) :: xy(2, nnode)
    integer, intent(in) :: itri(3, ntri), ibedge(2, nbedge), ibmark(nbedge)
    procedure(scalar_field) :: fsrc
    integer, intent(in) :: iopt(10)
    real(dp), intent(in) :: ropt(10)
    real(dp), intent(inout) :: u(nnode)
    real(dp), intent(out) :: q(6, ntri), bounds(4)
    integer, intent(out) :: info
    integer, intent(in), optional :: nbreak
    real(dp), intent(in), optional :: xbreak(*)
    type(dssign_options_t) :: opt
    type(mesh_t) :: mesh
    logical, allocatable :: flipped(:)
    character(len=:), allocatable :: msg
    real(dp), allocatable :: breaks(:)
    integer :: arg, i, shift
    info = 0
    bounds = 0.0_dp
    q = 0.0_dp
    shift = merge(2, 0, present(nbreak))
    call dssign_output_options(iopt, opt)
    call dssign_mesh(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, mesh, flipped, arg, msg)
    if (arg == arg_no_memory) then
      info = info_failed
      call dssign_print(opt, 1, 'DSSIGN: INFO = ' // itoa(info) // ': ' // msg)
      return
    else if (arg /= 0) then
      call fail_arg(opt, info, arg, msg)
      return
    end if
    do i = 1, nnode
      if (.not. ieee_is_finite(fsrc(xy(1, i), xy(2, i)))) then
        call fail_arg(opt, info, 9, 'FSRC is not finite at node ' // itoa(i))
        return
      end if
    end do
    if (present(nbreak)) then
      if (nbreak < 0 .or. nbreak > max_breaks) then
        call fail_arg(opt, info, 10, 'NBREAK = ' // itoa(nbreak) // ' (expected 0..' // itoa(max_breaks) // ')')
        return
      end if
      breaks = xbreak(1:nbreak)
      if (.not. all(ieee_is_finite(breaks))) then
        call fail_arg(opt, info, 11, 'XBREAK has a value that is not finite')
        return
      end if
    end if
    call dssign_read_options(iopt, ropt, opt, arg, msg)
    if (arg /= 0) then
      call fail_arg(opt, info, arg + shift, msg)
      return
    end if
    if (opt%start_from_u .and. .not. all(ieee_is_finite(u))) then
      call fail_arg(opt, info, 12 + shift, 'IOPT(9) = 1 but the start U is not finite')
      return
    end if
    call dssign_analyse(iprob, mesh, fsrc, opt, itri, flipped, u, q, bounds, info, breaks)
    if (info < 0 .or. info == info_failed) then
      q = 0.0_dp
      bounds = 0.0_dp
    end if
  end subroutine dssign_run

  !> The printing options IOPT(4), IOPT(5), needed before any other check can report.
  subroutine dssign_output_options(iopt, opt)
    integer, intent(in) :: iopt(10)
    type(dssign_options_t), intent(inout) :: opt
    opt%verbosity = 0
    if (iopt(4) >= 0 .and. iopt(4) <= 2) opt%verbosity = iopt(4)
    opt%out = output_unit
    if (iopt(5) > 0) opt%out = iopt(5)
  end subroutine dssign_output_options

  !> Print msg on the options' unit when the verbosity is at least level.
  subroutine dssign_print(opt, level, msg)
    type(dssign_options_t), intent(in) :: opt
    integer, intent(in) :: level
    character(len=*), intent(in) :: msg
    integer :: ios
    if (opt%verbosity < level) return
    if (.not. unit_writable(opt%out)) return       ! never write on a unit the host did not open for writing
    write (opt%out, '(a)', iostat=ios) msg          ! a failed write is the host's unit's business: no stop
  end subroutine dssign_print

  !> True when unit u is connected and may be written (inquire: opened, WRITE= not 'NO').
  logical function unit_writable(u) result(ok)
    integer, intent(in) :: u
    character(len=16) :: wr
    logical :: opened
    integer :: ios
    ok = .false.
    inquire (unit=u, opened=opened, write=wr, iostat=ios)
    if (ios /= 0 .or. .not. opened) return
    ok = wr /= 'NO'
  end function unit_writable

  !> Arguments 1 to 8 of DSSIGN, in order, and the mesh they describe (triangles made
  !> counter-clockwise: all or none were clockwise, flipped marks those swapped; boundary
  !> sides found for P1 when NBEDGE = 0).  arg = 0 when all hold, else the first bad argument and msg.
  subroutine dssign_mesh(iprob, nnode, xy, ntri, itri, nbedge, ibedge, ibmark, mesh, flipped, arg, msg)
    integer, intent(in) :: iprob, nnode, ntri
    real(dp), intent(in) :: xy(:,:)
    integer, intent(in) :: itri(:,:)
    integer, intent(in) :: nbedge
    integer, intent(in) :: ibedge(:,:), ibmark(:)
    type(mesh_t), intent(out) :: mesh
    logical, allocatable, intent(out) :: flipped(:)
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    type(side_table_t) :: sides
    call check_sizes(iprob, nnode, xy, ntri, arg, msg)
    if (arg /= 0) return
    call check_triangles(xy, itri, mesh, flipped, arg, msg)
    if (arg /= 0) return
    call side_table_build(mesh, sides, arg, msg)
    if (arg /= 0) return
    if (nbedge < 0) then
      call bad(6, 'NBEDGE = ' // itoa(nbedge) // ' (expected >= 0)')
    else if (iprob == PROBLEM_P2 .and. nbedge == 0) then
      call bad(6, 'NBEDGE = 0: problem P2 needs the boundary sides and their markers')
    end if
    if (arg /= 0) return
    call check_boundary_sides(mesh%nnode, ibedge, sides, arg, msg)
    if (arg /= 0) return
    call check_markers(iprob, ibmark, arg, msg)
    if (arg /= 0) return
    call boundary_of(mesh, nbedge, ibedge, ibmark, sides, arg, msg)
  contains
    subroutine bad(k, text)
      integer, intent(in) :: k
      character(len=*), intent(in) :: text
      arg = k
      msg = text
    end subroutine bad
  end subroutine dssign_mesh

  !> IPROB (1), NNODE (2), XY (3), NTRI (4).
  subroutine check_sizes(iprob, nnode, xy, ntri, arg, msg)
    integer, intent(in) :: iprob, nnode
    real(dp), intent(in) :: xy(:,:)
    integer, intent(in) :: ntri
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    integer :: i
    arg = 0
    if (iprob /= PROBLEM_P1 .and. iprob /= PROBLEM_P2) then
      arg = 1
      msg = 'IPROB = ' // itoa(iprob) // ' (expected 1 or 2)'
      return
    end if
    if (nnode < 3) then
      arg = 2
      msg = 'NNODE = ' // itoa(nnode) // ' (expected >= 3)'
      return
    end if
    do i = 1, size(xy, 2)
      if (.not. all(ieee_is_finite(xy(:, i)))) then
        arg = 3
        msg = 'XY(:,' // itoa(i) // ') is not finite'
        return
      end if
    end do
    if (ntri < 1) then
      arg = 4
      msg = 'NTRI = ' // itoa(ntri) // ' (expected >= 1)'
    end if
  end subroutine check_sizes

  !> ITRI (5): vertex numbers in range, three distinct vertices, non-zero area, no triangle
  !> twice; one orientation: all counter-clockwise, or all clockwise (then all get vertices
  !> 2 and 3 swapped, as the mesh readers do, and flipped is set); a mix is a folded mesh.
  subroutine check_triangles(xy, itri, mesh, flipped, arg, msg)
    real(dp), intent(in) :: xy(:,:)
    integer, intent(in) :: itri(:,:)
    type(mesh_t), intent(inout) :: mesh
    logical, allocatable, intent(out) :: flipped(:)
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    real(dp) :: scale
    integer :: t, nnode, nflip, ist
    type(status_t) :: st
    arg = 0
    nnode = size(xy, 2)
    mesh%nnode = nnode
    mesh%ntri = size(itri, 2)
    allocate (mesh%xy(2, nnode), mesh%tri(3, mesh%ntri), flipped(mesh%ntri), stat=ist)
    if (no_memory(ist, 'a copy of the mesh', 2 * nnode + 4 * mesh%ntri, arg, msg)) return
    mesh%xy(:, :) = xy
    mesh%tri(:, :) = itri
    flipped = .false.
    scale = mesh_coordinate_scale(mesh)
    do t = 1, mesh%ntri
      arg = 5
      if (any(itri(:, t) < 1 .or. itri(:, t) > nnode)) then
        msg = 'triangle ' // itoa(t) // ' has a vertex index outside 1..' // itoa(nnode)
        return
      end if
      if (itri(1, t) == itri(2, t) .or. itri(2, t) == itri(3, t) .or. itri(3, t) == itri(1, t)) then
        msg = 'triangle ' // itoa(t) // ' repeats a vertex'
        return
      end if
      if (abs(mesh_triangle_area(mesh, t)) <= mesh_zero_area(mesh, t, scale)) then
        msg = 'triangle ' // itoa(t) // ' has zero area (collinear vertices)'
        return
      end if
      arg = 0
    end do
    call mesh_check_duplicates(mesh, st)
    if (st%code == 0) call mesh_orient_triangles(mesh, nflip, st)
    if (st%code /= 0) then
      arg = 5
      msg = st%msg(len('mesh: ') + 1:)
      return
    end if
    flipped = nflip > 0
  end subroutine check_triangles

  !> The side table of the mesh's triangles (ITRI, argument 5: no side in more than two
  !> triangles).  Linear in the number of triangles (buckets hold a node's few neighbours).
  subroutine side_table_build(mesh, sides, arg, msg)
    type(mesh_t), intent(in) :: mesh
    type(side_table_t), intent(out) :: sides
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    integer :: t, k, a, b, l, s, ist
    arg = 0
    allocate (sides%head(mesh%nnode + 1), sides%fill(mesh%nnode), sides%hi(3 * mesh%ntri), &
              sides%count(3 * mesh%ntri), sides%from(2, 3 * mesh%ntri), stat=ist)
    if (no_memory(ist, 'the sides of the triangles', 2 * mesh%nnode + 12 * mesh%ntri + 1, arg, msg)) return
    sides%head = 0
    sides%fill = 0
    sides%hi = 0
    sides%count = 0
    sides%from = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        l = min(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        sides%head(l + 1) = sides%head(l + 1) + 1
      end do
    end do
    sides%head(1) = 1
    do l = 1, mesh%nnode
      sides%head(l + 1) = sides%head(l + 1) + sides%head(l)
    end do
    do t = 1, mesh%ntri
      do k = 1, 3
        a = mesh%tri(k, t)
        b = mesh%tri(mod(k, 3) + 1, t)
        l = min(a, b)
        s = side_find(sides, l, max(a, b))
        if (s == 0) then
          s = sides%head(l) + sides%fill(l)
          sides%fill(l) = sides%fill(l) + 1
          sides%hi(s) = max(a, b)
          sides%from(:, s) = [a, b]
        end if
        sides%count(s) = sides%count(s) + 1
        if (sides%count(s) > 2) then
          arg = 5
          msg = 'the side (' // itoa(l) // ',' // itoa(max(a, b)) // &
            ') is shared by more than two triangles (third: ' // itoa(t) // ')'
          return
        end if
      end do
    end do
    sides%nbside = count(sides%count == 1)
  end subroutine side_table_build

  !> The slot of side (l, m), l < m, or 0 when no triangle has it.
  integer function side_find(sides, l, m) result(s)
    type(side_table_t), intent(in) :: sides
    integer, intent(in) :: l, m
    integer :: r
    s = 0
    do r = sides%head(l), sides%head(l) + sides%fill(l) - 1
      if (sides%hi(r) == m) then
        s = r
        return
      end if
    end do
  end function side_find

  !> IBEDGE (7): every listed side is a boundary side of the triangles, once; all are listed.
  subroutine check_boundary_sides(nnode, ibedge, sides, arg, msg)
    integer, intent(in) :: nnode
    integer, intent(in) :: ibedge(:,:)
    type(side_table_t), intent(in) :: sides
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    logical, allocatable :: listed(:)
    integer :: j, a, b, p, lo, nbedge, ist
    arg = 0
    nbedge = size(ibedge, 2)
    allocate (listed(size(sides%hi)), stat=ist)
    if (no_memory(ist, 'the boundary side flags', size(sides%hi), arg, msg)) return
    listed = .false.
    do j = 1, nbedge
      a = ibedge(1, j)
      b = ibedge(2, j)
      arg = 7
      if (min(a, b) < 1 .or. max(a, b) > nnode) then
        msg = 'boundary side ' // itoa(j) // ' has a node index outside 1..' // itoa(nnode)
        return
      end if
      p = side_find(sides, min(a, b), max(a, b))
      if (p == 0) then
        msg = 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is not a side of any triangle'
        return
      end if
      if (sides%count(p) /= 1) then
        msg = 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is an interior side'
        return
      end if
      if (listed(p)) then
        msg = 'boundary side ' // itoa(j) // ' (' // itoa(a) // ',' // itoa(b) // ') is listed twice'
        return
      end if
      arg = 0
      listed(p) = .true.
    end do
    if (nbedge > 0 .and. nbedge < sides%nbside) then
      do lo = 1, nnode
        do p = sides%head(lo), sides%head(lo) + sides%fill(lo) - 1
          if (sides%count(p) == 1 .and. .not. listed(p)) then
            arg = 7
            msg = 'the boundary side (' // itoa(lo) // ',' // itoa(sides%hi(p)) // ') is missing: all ' // &
              itoa(sides%nbside) // ' boundary sides must be listed, found ' // itoa(nbedge)
            return
          end if
        end do
      end do
    end if
  end subroutine check_boundary_sides

  !> IBMARK (8): 1 = Gamma_u or 2 = Gamma_a; P1 only 2; P2 needs a Gamma_u side.
  subroutine check_markers(iprob, ibmark, arg, msg)
    integer, intent(in) :: iprob
    integer, intent(in) :: ibmark(:)
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    integer :: j
    arg = 8
    do j = 1, size(ibmark)
      if (ibmark(j) /= mark_gamma_u .and. ibmark(j) /= mark_gamma_a) then
        msg = 'IBMARK(' // itoa(j) // ') = ' // itoa(ibmark(j)) // ' (expected 1 = Gamma_u or 2 = Gamma_a)'
        return
      end if
      if (iprob == PROBLEM_P1 .and. ibmark(j) /= mark_gamma_a) then
        msg = 'IBMARK(' // itoa(j) // ') = 1: problem P1 has Signorini conditions on all of Gamma (use 2)'
        return
      end if
    end do
    if (iprob == PROBLEM_P2 .and. count(ibmark == mark_gamma_u) == 0) then
      msg = 'no side has IBMARK = 1: problem P2 needs a non-empty Gamma_u'
      return
    end if
    arg = 0
  end subroutine check_markers

  !> The boundary sides of the mesh: the caller's list, or for P1 without one the sides of
  !> one triangle, oriented as in it (domain on the left), all on Gamma_a.
  !> arg = arg_no_memory and msg when out of memory.
  subroutine boundary_of(mesh, nbedge, ibedge, ibmark, sides, arg, msg)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: nbedge
    integer, intent(in) :: ibedge(:,:), ibmark(:)
    type(side_table_t), intent(in) :: sides
    integer, intent(inout) :: arg
    character(len=:), allocatable, intent(inout) :: msg
    integer :: j, lo, p, ist
    mesh%nbedge = merge(nbedge, sides%nbside, nbedge > 0)
    allocate (mesh%bedge_nodes(2, mesh%nbedge), mesh%bedge_marker(mesh%nbedge), stat=ist)
    if (no_memory(ist, 'the boundary sides', 3 * mesh%nbedge, arg, msg)) return
    if (nbedge > 0) then
      mesh%bedge_nodes(:, :) = ibedge(:, 1:nbedge)
      mesh%bedge_marker(:) = ibmark(1:nbedge)
      return
    end if
    j = 0
    do lo = 1, mesh%nnode
      do p = sides%head(lo), sides%head(lo) + sides%fill(lo) - 1
        if (sides%count(p) /= 1) cycle
        j = j + 1
        mesh%bedge_nodes(:, j) = sides%from(:, p)
      end do
    end do
    mesh%bedge_marker = mark_gamma_a
  end subroutine boundary_of

  !> IOPT(1..10), ROPT(1..10), 0 = default in every slot; arg = 10 / 11 for a value out of
  !> range (the slot is named in msg).
  subroutine dssign_read_options(iopt, ropt, opt, arg, msg)
    integer, intent(in) :: iopt(10)
    real(dp), intent(in) :: ropt(10)
    type(dssign_options_t), intent(inout) :: opt
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    call read_integer_options(iopt, opt, arg, msg)
    if (arg == 0) call read_real_options(ropt, opt, arg, msg)
  end subroutine dssign_read_options

  !> IOPT(1..10).
  subroutine read_integer_options(iopt, opt, arg, msg)
    integer, intent(in) :: iopt(10)
    type(dssign_options_t), intent(inout) :: opt
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    arg = 10
    opt%primal_method = merge(default_primal_method, iopt(1), iopt(1) == 0)
    opt%max_iter = merge(default_max_iter, iopt(2), iopt(2) == 0)
    opt%dual_method = iopt(3)
    opt%dual_max_iter = merge(default_dual_max_iter, iopt(7), iopt(7) == 0)
    opt%check_every = merge(default_check_every, iopt(8), iopt(8) == 0)
    opt%start_from_u = iopt(9) == 1
    opt%p1_space = iopt(10)
    if (opt%primal_method < 1 .or. opt%primal_method > 2) then
      msg = 'IOPT(1) = ' // itoa(iopt(1)) // ' (primal solver: 0 default, 1 psor, 2 active set)'
    else if (opt%max_iter < 1) then
      msg = 'IOPT(2) = ' // itoa(iopt(2)) // ' (primal iteration limit: 0 default or >= 1)'
    else if (opt%dual_method < 0 .or. opt%dual_method > dual_off) then
      msg = 'IOPT(3) = ' // itoa(iopt(3)) // ' (dual: 0/1 default method, 2 uzawa, 3 none)'
    else if (iopt(4) < 0 .or. iopt(4) > 2) then
      msg = 'IOPT(4) = ' // itoa(iopt(4)) // ' (printing: 0, 1 or 2)'
    else if (iopt(5) < 0) then
      msg = 'IOPT(5) = ' // itoa(iopt(5)) // ' (output unit: 0 default or > 0)'
    else if (iopt(4) > 0 .and. iopt(5) > 0 .and. .not. unit_writable(max(iopt(5), 1))) then
      msg = 'IOPT(5) = ' // itoa(iopt(5)) // ' names a unit that is not open for writing (IOPT(4) = ' // &
        itoa(iopt(4)) // ' asks for messages; open it for writing, or 0: standard output)'
    else if (iopt(6) < 0 .or. iopt(6) > 5) then
      msg = 'IOPT(6) = ' // itoa(iopt(6)) // ' (ordering: 0/1 amd, 2 metis, 3 best, 4 natural, 5 nd)'
    else if (opt%dual_max_iter < 1) then
      msg = 'IOPT(7) = ' // itoa(iopt(7)) // ' (dual iteration limit: 0 default or >= 1)'
    else if (opt%check_every < 1) then
      msg = 'IOPT(8) = ' // itoa(iopt(8)) // ' (sweeps between residuals: 0 default or >= 1)'
    else if (iopt(9) < 0 .or. iopt(9) > 1) then
      msg = 'IOPT(9) = ' // itoa(iopt(9)) // ' (start: 0 zero, 1 U on entry)'
    else if (iopt(10) < 0 .or. iopt(10) > p1_space_paper) then
      msg = 'IOPT(10) = ' // itoa(iopt(10)) // ' (P1 dual space: 0/1 RT1, 2 the paper''s continuous P1 fields)'
    else
      arg = 0
    end if
    select case (iopt(6))
    case (2)
      opt%ordering = ORDERING_METIS
    case (3)
      opt%ordering = ORDERING_BEST
    case (4)
      opt%ordering = ORDERING_NATURAL
    case (5)
      opt%ordering = ORDERING_GEOMETRIC
    case default
      opt%ordering = ORDERING_AMD
    end select
  end subroutine read_integer_options

  !> ROPT(1..10).
  subroutine read_real_options(ropt, opt, arg, msg)
    real(dp), intent(in) :: ropt(10)
    type(dssign_options_t), intent(inout) :: opt
    integer, intent(out) :: arg
    character(len=:), allocatable, intent(out) :: msg
    integer :: k
    arg = 11
    do k = 1, 10
      if (.not. ieee_is_finite(ropt(k))) then
        msg = 'ROPT(' // itoa(k) // ') is not finite'
        return
      end if
    end do
    opt%tol = merge(default_tol, ropt(1), ropt(1) == 0.0_dp)
    opt%omega = merge(default_omega, ropt(2), ropt(2) == 0.0_dp)
    opt%dual_tol = merge(default_dual_tol, ropt(3), ropt(3) == 0.0_dp)
    opt%dual_tol_h2 = merge(default_dual_tol_h2, ropt(4), ropt(4) == 0.0_dp)
    opt%rho = ropt(5)
    opt%penalty = ropt(6)
    opt%admissible = merge(default_admissible, ropt(7), ropt(7) == 0.0_dp)
    if (.not. (opt%tol > 0.0_dp .and. opt%tol < 1.0_dp)) then
      msg = 'ROPT(1) = ' // rtoa(ropt(1)) // ' (primal tolerance: 0 default or in (0, 1))'
    else if (.not. (opt%omega > 0.0_dp .and. opt%omega < 2.0_dp)) then
      msg = 'ROPT(2) = ' // rtoa(ropt(2)) // ' (SOR omega: 0 default or in (0, 2))'
    else if (.not. (opt%dual_tol > 0.0_dp .and. opt%dual_tol < 1.0_dp)) then
      msg = 'ROPT(3) = ' // rtoa(ropt(3)) // ' (dual tolerance: 0 default or in (0, 1))'
    else if (opt%dual_tol_h2 < 0.0_dp) then
      msg = 'ROPT(4) = ' // rtoa(ropt(4)) // ' (dual tol_h2: 0 default or > 0)'
    else if (opt%rho < 0.0_dp) then
      msg = 'ROPT(5) = ' // rtoa(ropt(5)) // ' (Uzawa step: 0 automatic or > 0)'
    else if (opt%penalty < 0.0_dp) then
      msg = 'ROPT(6) = ' // rtoa(ropt(6)) // ' (augmented Lagrangian penalty: 0 automatic or > 0)'
    else if (opt%admissible < 0.0_dp) then
      msg = 'ROPT(7) = ' // rtoa(ropt(7)) // ' (admissible divergence defect: 0 default or > 0)'
    else if (any(ropt(8:10) /= 0.0_dp)) then
      msg = 'ROPT(8:10) are reserved: must be 0'
    else
      arg = 0
    end if
  end subroutine read_real_options

  !> One level of the analysis on the checked mesh: the topology and the geometry checks
  !> (mesh_check_geometry: one piece, no overlap; arg 5 on failure), the P2 assumption (A2)
  !> when the dual runs (arg 5 / 8 on failure), the primal solve from u (zero unless
  !> IOPT(9) = 1), the dual field and bounds; u, q (the dual field at the caller's
  !> vertices), bounds and info as documented at DSSIGN.
  subroutine dssign_analyse(iprob, mesh, fsrc, opt, itri, flipped, u, q, bounds, info, breaks)
    integer, intent(in) :: iprob
    type(mesh_t), intent(inout) :: mesh
    procedure(scalar_field) :: fsrc
    type(dssign_options_t), intent(in) :: opt
    integer, intent(in) :: itri(:,:)
    logical, intent(in) :: flipped(:)
    real(dp), intent(inout) :: u(:)
    real(dp), intent(inout) :: q(:,:)
    real(dp), intent(inout) :: bounds(4)
    integer, intent(inout) :: info
    real(dp), allocatable, intent(in) :: breaks(:)     !! break lines of f (unallocated: none)
    type(analysis_problem_t) :: problem
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    call mesh_build_topology(mesh, st)
    if (st%code == DS_OK) call mesh_check_geometry(mesh, st)
    if (st%code /= DS_OK) then
      call fail_arg(opt, info, 5, st%msg)
      return
    end if
    if (iprob == PROBLEM_P2 .and. opt%dual_method /= dual_off) then
      call dual_p2_check_assumptions(mesh, mesh%bedge_marker == mark_gamma_a, st)
      if (st%code /= DS_OK) then
        call fail_arg(opt, info, 8, st%msg)
        return
      end if
    end if
    problem%kind = iprob
    problem%gamma_u = [merge(mark_gamma_u, 0, any(mesh%bedge_marker == mark_gamma_u))]
    problem%gamma_a = [merge(mark_gamma_a, 0, any(mesh%bedge_marker == mark_gamma_a))]
    allocate (problem%f, source=function_field(fsrc))      ! small: a field object
    if (allocated(breaks)) problem%x_breaks = breaks
    call mesh_move(mesh, problem%mesh)
    if (.not. opt%start_from_u) u = 0.0_dp
    call analysis_start(an, problem, settings_of(opt, iprob), st, u_start=u)
    if (is_ok(st)) call analysis_next_level(an, res, st)
    if (allocated(res%u)) u = res%u
    if (.not. is_ok(st)) then
      info = info_failed
      call dssign_print(opt, 1, 'DSSIGN: INFO = ' // itoa(info) // ': ' // st%msg)
      return
    end if
    call report(opt, iprob, res, count(flipped), info)
    if (res%has_dual) then
      bounds = [res%est, res%energy_lo, res%energy_hi, res%oscillation]
      call vertex_field(iprob, an%mesh, problem, res, itri, flipped, q)
      if (.not. (all(ieee_is_finite(q)) .and. all(ieee_is_finite(bounds)))) then
        info = info_failed
        call dssign_print(opt, 1, 'DSSIGN: INFO = ' // itoa(info) // ': the dual field or the bounds are not ' // &
          'finite (FSRC is NaN or infinite somewhere in the domain, or so large that they overflow)')
        return
      end if
      call dssign_print(opt, 1, 'DSSIGN: E = ' // rtoa(bounds(1)) // ', energy bounds ' // rtoa(bounds(2)) // &
        ' <= (f,u) <= ' // rtoa(bounds(3)))
    end if
    if (info > 0) call dssign_print(opt, 1, 'DSSIGN: INFO = ' // itoa(info))
  end subroutine dssign_analyse

  !> True when the allocation status ist is non-zero: then arg = arg_no_memory and msg the
  !> out-of-memory message naming what and its size (dualsig_alloc).
  logical function no_memory(ist, what, nelem, arg, msg)
    integer, intent(in) :: ist                  !! the stat= of the allocate
    character(len=*), intent(in) :: what        !! what was allocated
    integer, intent(in) :: nelem                !! 4-byte words requested
    integer, intent(inout) :: arg
    character(len=:), allocatable, intent(inout) :: msg
    type(status_t) :: st
    no_memory = alloc_failed(ist, st, what, nelem, BYTES_INT)
    if (.not. no_memory) return
    arg = arg_no_memory
    msg = st%msg
  end function no_memory

  !> INFO = -k for argument k, the message printed when IOPT(4) >= 1.
  subroutine fail_arg(opt, info, k, msg)
    type(dssign_options_t), intent(in) :: opt
    integer, intent(inout) :: info
    integer, intent(in) :: k
    character(len=*), intent(in) :: msg
    info = -k
    call dssign_print(opt, 1, 'DSSIGN: INFO = ' // itoa(info) // ' (argument ' // itoa(k) // '): ' // msg)
  end subroutine fail_arg

  !> The analysis settings of the options: one level, the caller's solvers.
  function settings_of(opt, iprob) result(settings)
    type(dssign_options_t), intent(in) :: opt
    integer, intent(in) :: iprob
    type(analysis_settings_t) :: settings
    settings%levels = 1
    settings%method = trim(merge('active_set', 'psor      ', opt%primal_method == 2))
    settings%max_iter = opt%max_iter
    settings%tol = opt%tol
    settings%omega = opt%omega
    settings%check_every = opt%check_every
    settings%ordering = opt%ordering
    settings%dual = opt%dual_method /= dual_off
    if (iprob == PROBLEM_P1) then
      settings%dual_method = trim(merge('uzawa     ', 'active_set', opt%dual_method == 2))
    else
      settings%dual_method = trim(merge('uzawa    ', 'augmented', opt%dual_method == 2))
    end if
    settings%dual_rho = opt%rho
    settings%dual_max_iter = opt%dual_max_iter
    settings%dual_tol = opt%dual_tol
    settings%dual_tol_h2 = opt%dual_tol_h2
    settings%dual_penalty = opt%penalty
    settings%admissible_defect = opt%admissible
    settings%keep_fields = .true.
    ! P1: RT1 (H(div), the tight bounds) unless IOPT(10) asks for the paper's continuous field
    if (opt%p1_space == p1_space_paper) then
      settings%dual_space = 'paper'
    else
      settings%dual_space = 'hdiv'
    end if
  end function settings_of

  !> INFO bits of the level's warnings, and the messages IOPT(4) asks for.
  subroutine report(opt, iprob, res, nflipped, info)
    type(dssign_options_t), intent(in) :: opt
    integer, intent(in) :: iprob
    type(level_result_t), intent(in) :: res
    integer, intent(in) :: nflipped
    integer, intent(inout) :: info
    integer :: k
    if (res%primal_limit) info = info + info_primal_limit
    if (res%dual_limit) info = info + info_dual_limit
    if (res%has_dual .and. .not. res%certified) info = info + info_not_admissible
    call dssign_print(opt, 2, 'DSSIGN: primal ' // trim(merge('active set', 'psor      ', opt%primal_method == 2)) // &
      ': ' // itoa(res%primal_iters) // ' iterations, KKT residual ' // rtoa(res%kkt_residual))
    do k = 1, res%nwarnings
      call dssign_print(opt, 1, 'DSSIGN: warning: ' // res%warnings(k)%msg)
    end do
    call dssign_print(opt, 1, 'DSSIGN: problem P' // itoa(iprob) // ', ' // itoa(res%nnode) // ' nodes, ' // &
      itoa(res%ntri) // ' triangles, ' // itoa(nflipped) // ' clockwise triangles reoriented')
    if (res%has_dual .and. iprob == PROBLEM_P1) then
      call dssign_print(opt, 2, 'DSSIGN: dual ' // trim(res%dual_method) // ': ' // itoa(res%dual_p1%iterations) // &
        ' iterations, residual ' // rtoa(res%dual_p1%residual) // ', constraints ' // itoa(res%dual_p1%nconstraints) // &
        ', active ' // itoa(res%dual_p1%nactive))
    else if (res%has_dual) then
      call dssign_print(opt, 2, 'DSSIGN: dual ' // trim(res%dual_method) // ': ' // itoa(res%dual_p2%iterations) // &
        ' iterations, divergence defect ' // rtoa(res%dual_p2%defect) // ', constraints ' // &
        itoa(res%dual_p2%nconstraints) // ', active ' // itoa(res%dual_p2%nactive))
    end if
  end subroutine report

  !> Q(6, NTRI): the dual field at the caller's vertices of each triangle: P1 in the paper's
  !> space the continuous q_h at the nodes; P1 in RT1 and P2 the field's limit from inside the
  !> triangle (q_h resp. lambda_h; only the normal component is continuous across sides).
  subroutine vertex_field(iprob, mesh, problem, res, itri, flipped, q)
    integer, intent(in) :: iprob
    type(mesh_t), intent(in) :: mesh
    type(analysis_problem_t), intent(in) :: problem
    type(level_result_t), intent(in) :: res
    integer, intent(in) :: itri(:,:)
    logical, intent(in) :: flipped(:)
    real(dp), intent(inout) :: q(:,:)
    real(dp) :: bary(3)
    integer :: t, k, node, kin
    do t = 1, size(itri, 2)
      do k = 1, 3
        if (iprob == PROBLEM_P1 .and. allocated(res%q)) then
          node = itri(k, t)
          q(2 * k - 1:2 * k, t) = res%q(2 * node - 1:2 * node)
          cycle
        end if
        ! the caller's vertex k is vertex kin of the (possibly reoriented) triangle
        kin = k
        if (flipped(t) .and. k > 1) kin = 5 - k
        bary = 0.0_dp
        bary(kin) = 1.0_dp
        if (iprob == PROBLEM_P1) then
          q(2 * k - 1:2 * k, t) = hdiv_point_value(mesh, res%q_hdiv, t, bary)
        else
          q(2 * k - 1:2 * k, t) = dual_p2_lambda(res%lambda, mesh, problem%f, t, bary)
        end if
      end do
    end do
  end subroutine vertex_field

  !> DSBQP's definiteness check: .false. when the smallest Ritz value of the Jacobi-scaled A
  !> (jacobi_scaled_extremes, at most definiteness_steps Lanczos steps) is below
  !> -indefinite_rel_tol times the largest: A is then indefinite.  .true. says only that
  !> none was found.
  logical function f77_no_negative_curvature(a) result(ok)
    type(csr_t), intent(in) :: a
    real(dp) :: lmin, lmax
    integer :: steps
    type(status_t) :: st_l
    logical, allocatable :: everywhere(:)
    allocate (everywhere(a%n), stat=steps)
    ok = .true.
    if (steps /= 0) return                  ! no memory for the check: the solve will say so
    everywhere = .true.
    call jacobi_scaled_extremes(a, everywhere, definiteness_steps, 0.0_dp, lmin, lmax, steps, st_l)
    if (is_ok(st_l)) ok = .not. (lmin < -indefinite_rel_tol * abs(lmax))
  end function f77_no_negative_curvature

  !> The transpose (CSC of the input = CSR of A^T) by a counting sort: the entries of each
  !> output row come in increasing input-row order.  Applied twice, it sorts the columns.
  subroutine f77_transpose_csr(rp_in, ci_in, v_in, rp_out, ci_out, v_out, st)
    integer, intent(in) :: rp_in(:), ci_in(:)
    real(dp), intent(in) :: v_in(:)
    integer, allocatable, intent(out) :: rp_out(:), ci_out(:)
    real(dp), allocatable, intent(out) :: v_out(:)
    type(status_t), intent(inout) :: st
    integer :: r, q, c, m, ist
    m = size(rp_in) - 1
    allocate (rp_out(m + 1), ci_out(size(ci_in)), v_out(size(ci_in)), stat=ist)
    if (alloc_failed(ist, st, 'a copy of the matrix', m + 1 + 3 * size(ci_in), BYTES_INT)) return
    rp_out = 0
    do q = 1, size(ci_in)
      rp_out(ci_in(q) + 1) = rp_out(ci_in(q) + 1) + 1
    end do
    rp_out(1) = 1
    do r = 1, m
      rp_out(r + 1) = rp_out(r + 1) + rp_out(r)
    end do
    do r = 1, m
      do q = rp_in(r), rp_in(r + 1) - 1
        c = ci_in(q)
        ci_out(rp_out(c)) = r
        v_out(rp_out(c)) = v_in(q)
        rp_out(c) = rp_out(c) + 1
      end do
    end do
    ! rp_out(c) now points one past row c: shift back
    do r = m, 1, -1
      rp_out(r + 1) = rp_out(r)
    end do
    rp_out(1) = 1
  end subroutine f77_transpose_csr
end module dualsig_f77_adapter
