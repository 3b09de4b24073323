!> Run configuration: namelist files for batch runs.
!>
!> A file is a sequence of runs.  Each run starts with a `&run` group; the `&mesh`,
!> `&solver`, `&dual` and `&problem` groups that follow it (before the next `&run`) belong
!> to that run, in any order, each at most once.  `&problem` describes one's own problem
!> (kind, the load as an expression, per region or as nodal values, an optional exact
!> solution) instead of a scene of the catalogue; its expressions are compiled here, so a
!> syntax error names the file, the variable and the column.
!>
!> Lines are stored as strings of their own length (a line may hold an expression of many
!> thousand characters; at most max_line_len), so blank or short lines cost little.  Variables not given keep their defaults, which are reset
!> for every run, so each run is self-contained.  Comments start with '!'.
!>
!> Before the namelist read every assignment is checked against the group's variable
!> list (unknown variable -> error naming it and the line); when the read fails the
!> assignments are re-read one at a time to name the variable whose value is invalid.
!> Values are then checked for range.  Every message names the file, the group, the
!> line and what was expected.  See doc/user-guide.md for the variables and their defaults.
!>
!> Input files named in a run (&mesh file, &problem f_file) are relative to the folder of
!> the namelist file (absolute paths unchanged); a relative path found there is replaced
!> by that path.  For namelists written for the working directory, a path not found there
!> but found relative to the working directory is kept, and the run's `path_note` says so
!> (the driver prints it as a warning).  Output paths (&run output) stay relative to the
!> working directory.
module dualsig_io_config
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: ieee_exceptions, only: ieee_usual, ieee_get_halting_mode, ieee_set_halting_mode
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT, DS_ERR_IO
  use dualsig_scenes, only: max_markers
  use dualsig_strings, only: itoa, rtoa, lower
  use dualsig_expression, only: expression_t, expression_compile_input
  use dualsig_io_files, only: regular_file_size, input_file_ok
  use dualsig_alloc, only: alloc_failed
  implicit none
  private

  public :: run_config_t, read_config_file, config_echo, config_text, max_line_len, max_breaks, region_value_len

  integer, parameter :: max_line_len = 65536    !! longest accepted line of a namelist file
  !> The value of an unset slot of a marker list while &run is read (no marker is negative)
  integer, parameter :: unset_marker = -huge(1)
  integer, parameter :: read_chunk = 4096       !! characters read at a time from a line
  integer, parameter :: max_breaks = 16         !! &problem breaks: most abscissae
  integer, parameter :: region_value_len = 2048 !! &problem f_region_values: longest expression
  real(dp), parameter :: unset_break = huge(1.0_dp)  !! marks unused slots of breaks while reading
  integer, parameter :: max_levels = 14         !! largest accepted number of mesh levels
  integer, parameter :: wide = 512              !! string length for reading (longer values are rejected)
  integer, parameter :: marker_name_len = 64    !! longest physical-group name in gamma_u/a_names

  character(len=*), parameter :: run_items = &
    'title scene output gamma_u_markers gamma_a_markers vtk vtu_format latex gamma_u_names gamma_a_names max_memory_gb'
  character(len=*), parameter :: mesh_items = &
    'source file x0 x1 y0 y1 nx ny n pattern levels format'
  character(len=*), parameter :: solver_items = &
    'method omega omega_auto tol max_iter check_every nested'
  character(len=*), parameter :: dual_items = &
    'enabled method rho tol tol_h2 max_iter ordering inner particular space algebraic_share'
  character(len=*), parameter :: adapt_items = &
    'enabled theta tol max_ndof max_seconds min_growth algebraic_share'
  character(len=*), parameter :: problem_items = &
    'kind f u_exact breaks f_regions f_region_values f_file'

  type :: run_config_t
    character(len=:), allocatable :: source_file   !! the namelist file
    !> why an input path was taken relative to the working directory, not to the namelist's
    !> folder (unallocated or '': it was not)
    character(len=:), allocatable :: path_note
    integer :: line = 0                            !! line of the &run group
    ! &run
    character(len=80) :: title = ''
    character(len=32) :: scene = 'p2_contact'
    character(len=256) :: output = 'out/dualsig'
    integer :: gamma_u_markers(max_markers) = 0    !! all 0: the scene's default
    integer :: gamma_a_markers(max_markers) = 0    !! all 0: the scene's default
    !> Gmsh physical curve names forming Gamma_u / Gamma_a (instead of the marker lists; '' = unused)
    character(len=marker_name_len) :: gamma_u_names(max_markers) = ''
    character(len=marker_name_len) :: gamma_a_names(max_markers) = ''
    logical :: vtk = .false.                       !! write <output>_levelLL.vtu and <output>.pvd
    character(len=16) :: vtu_format = 'binary'     !! encoding of the .vtu arrays: 'binary' (zlib) or 'ascii'
    logical :: latex = .false.                     !! write the error table also as <output>.tex
    !> memory a level may need (GB, estimated from its mesh before it starts); 0 = the
    !> machine's available memory (MemAvailable of /proc/meminfo)
    real(dp) :: max_memory_gb = 0.0_dp
    ! &mesh
    character(len=16) :: mesh_source = 'rectangle'
    character(len=256) :: mesh_file = ''
    character(len=16) :: mesh_format = 'auto'     !! auto, dualsig, gmsh or triangle
    real(dp) :: x0 = 0.0_dp, x1 = 1.0_dp, y0 = 0.0_dp, y1 = 1.0_dp
    integer :: nx = 2, ny = 2, n = 1
    character(len=16) :: pattern = 'right'
    integer :: levels = 4
    ! &solver
    !> primal solver; 'auto' (the default): 'schur' or 'active_set' by the number of bounded
    !> unknowns (analysis_settings_t); 'psor' is the paper's projected SOR
    character(len=16) :: method = 'auto'
    real(dp) :: omega = 1.0_dp
    logical :: omega_auto = .false.
    real(dp) :: tol = 1.0e-10_dp
    integer :: max_iter = 200000
    integer :: check_every = 10
    logical :: nested = .true.
    ! &dual
    logical :: dual_enabled = .false.
    character(len=16) :: dual_method = 'default'
    real(dp) :: dual_rho = 0.0_dp
    real(dp) :: dual_tol = 1.0e-10_dp
    real(dp) :: dual_tol_h2 = 1.0e-4_dp
    integer :: dual_max_iter = 20000
    character(len=16) :: dual_ordering = 'nd'     !! every CHOLMOD factorisation of the run
    character(len=16) :: dual_inner = 'schur'     !! P2 augmented: inner solver, 'schur' or 'active_set'
    character(len=16) :: dual_particular = 'polynomial' !! P2 lambda^f: 'polynomial' or 'stream' (the paper's)
    character(len=16) :: dual_space = 'hdiv'      !! P1: 'hdiv' (RT1, tight bounds) or 'paper' (Section 3)
    !> the share of est the iterative dual solve of a uniform level may leave, 0 <= share < 1
    !> (0: exact; adaptive steps: adapt_algebraic_share)
    real(dp) :: dual_algebraic_share = 1.0e-3_dp
    ! &adapt: solve -> estimate -> mark (Doerfler) -> refine (newest-vertex bisection)
    logical :: adapt_enabled = .false.
    real(dp) :: adapt_theta = 0.5_dp               !! Doerfler parameter, 0 < theta <= 1
    real(dp) :: adapt_tol = 0.0_dp                 !! target of sqrt(est)/sqrt(energy_lo); 0 = none
    integer :: adapt_max_ndof = 0                  !! 0 = no limit
    real(dp) :: adapt_max_seconds = 0.0_dp         !! 0 = no limit
    real(dp) :: adapt_min_growth = 1.5_dp          !! growth of the unknowns a step at least adds, 1 to 2
    !> the share of est the algebraic error of a step's dual may add, 0 <= share < 1 (0: exact)
    real(dp) :: adapt_algebraic_share = 1.0e-3_dp
    ! &problem (one's own problem instead of a scene)
    logical :: scene_given = .false.               !! &run scene was given explicitly
    logical :: has_problem = .false.               !! a &problem group was given
    integer :: problem_line = 0                    !! its line
    character(len=2) :: problem_kind = 'P2'        !! 'P1' or 'P2'
    !> the load as an expression in x and y ('' unless given; unallocated counts as '')
    character(len=:), allocatable :: f
    character(len=:), allocatable :: u_exact       !! the exact solution, for verification
    character(len=:), allocatable :: f_file        !! nodal values of f on the coarse mesh
    integer :: nbreaks = 0                         !! abscissae of vertical lines where f jumps or kinks
    real(dp) :: breaks(max_breaks) = 0.0_dp
    !> region loads: Gmsh physical surface names or tags, Triangle region attributes ...
    character(len=marker_name_len) :: f_regions(max_markers) = ''
    !> ... and the expression of f on each of them
    character(len=region_value_len) :: f_region_values(max_markers) = ''
  end type run_config_t

  !> A line of text of its own length.
  type :: text_line_t
    character(len=:), allocatable :: s
  end type text_line_t

  type :: group_t
    character(len=32) :: name = ''
    integer :: line = 0                              !! line of the '&name'
    type(text_line_t), allocatable :: text(:)        !! assignments (comments removed)
    integer, allocatable :: text_line(:)             !! source line of each assignment
  end type group_t

contains

  !> Read every run of the namelist file `path`.
  subroutine read_config_file(path, runs, st)
    character(len=*), intent(in) :: path
    type(run_config_t), allocatable, intent(out) :: runs(:)
    type(status_t), intent(out) :: st
    type(text_line_t), allocatable :: lines(:)
    type(group_t), allocatable :: groups(:)
    integer :: g, r, nrun
    logical :: seen(5)                    ! &mesh, &solver, &dual, &problem, &adapt in the current run
    character(len=*), parameter :: member_groups(5) = [character(len=8) :: 'mesh', 'solver', 'dual', 'problem', &
                                                       'adapt']
    integer :: kgroup, ist

    allocate (runs(0))                              ! small: empty
    call read_lines(path, lines, st)
    if (st%code /= 0) return
    call split_groups(path, lines, groups, st)
    if (st%code /= 0) return
    deallocate (lines)
    nrun = count(groups%name == 'run')
    if (nrun == 0) then
      call set_error(st, DS_ERR_INPUT, trim(path) // ': no &run group found (a run starts with &run)')
      return
    end if
    deallocate (runs)
    allocate (runs(nrun), stat=ist)
    if (alloc_failed(ist, st, 'the runs of ' // trim(path), nrun, storage_size(runs) / 8)) return
    r = 0
    seen = .false.
    do g = 1, size(groups)
      kgroup = findloc(member_groups, trim(groups(g)%name), dim=1)
      if (groups(g)%name == 'run') then
        r = r + 1
        runs(r)%source_file = path
        runs(r)%line = groups(g)%line
        seen = .false.
        call apply_group(path, groups(g), run_items, runs(r), st)
      else if (kgroup > 0) then
        if (r == 0) then
          call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(groups(g)%line) // &
            ': group &' // trim(groups(g)%name) // ' before the first &run group')
          return
        end if
        if (seen(kgroup)) then
          call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(groups(g)%line) // &
            ': second &' // trim(groups(g)%name) // ' group in the run of line ' // itoa(runs(r)%line))
          return
        end if
        seen(kgroup) = .true.
        select case (kgroup)
        case (1)
          call apply_group(path, groups(g), mesh_items, runs(r), st)
        case (2)
          call apply_group(path, groups(g), solver_items, runs(r), st)
        case (3)
          call apply_group(path, groups(g), dual_items, runs(r), st)
        case (5)
          call apply_group(path, groups(g), adapt_items, runs(r), st)
        case default
          runs(r)%has_problem = .true.
          runs(r)%problem_line = groups(g)%line
          call apply_group(path, groups(g), problem_items, runs(r), st)
        end select
      else
        call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(groups(g)%line) // &
          ': unknown namelist group &' // trim(groups(g)%name) // &
          did_you_mean(groups(g)%name, 'run mesh solver dual problem adapt', '&') // &
          '; expected &run, &mesh, &solver, &dual, &problem or &adapt')
        return
      end if
      if (st%code /= 0) return
    end do
    do r = 1, nrun
      call validate(runs(r), st)
      if (st%code /= 0) return
      call validate_problem(runs(r), st)
      if (st%code /= 0) return
      call resolve_input_paths(path, runs(r), st)
      if (st%code /= 0) return
    end do
  end subroutine read_config_file

  !> The input files of run cfg (&mesh file, &problem f_file) relative to the folder of the
  !> namelist file `path`: 'm.msh' in 'data/x.nml' becomes 'data/m.msh'.  Absolute paths,
  !> and all paths of a namelist in the working directory, are unchanged.  Fallback for
  !> namelists written for the working directory: a path that does not exist relative to
  !> the namelist but does relative to the working directory is kept, noted in
  !> cfg%path_note.  Error: a resolved path longer than &mesh file can hold.
  subroutine resolve_input_paths(path, cfg, st)
    character(len=*), intent(in) :: path
    type(run_config_t), intent(inout) :: cfg
    type(status_t), intent(inout) :: st
    character(len=:), allocatable :: dir, resolved
    integer :: k
    k = index(path, '/', back=.true.)
    if (k == 0) return
    dir = path(1:k)
    if (cfg%mesh_source == 'file') then
      resolved = resolved_input(dir, trim(cfg%mesh_file), '&mesh file', cfg)
      if (len(resolved) > len(cfg%mesh_file)) then
        call set_error(st, DS_ERR_INPUT, cfg%source_file // ': run of line ' // itoa(cfg%line) // &
          ': &mesh file relative to the namelist''s folder, ''' // resolved // ''', is longer than ' // &
          itoa(len(cfg%mesh_file)) // ' characters; expected a shorter path')
        return
      end if
      cfg%mesh_file = resolved
    end if
    if (len_trim(config_text(cfg%f_file)) > 0) cfg%f_file = resolved_input(dir, trim(cfg%f_file), '&problem f_file', cfg)
  end subroutine resolve_input_paths

  !> The input path `name` of item `what` resolved against the namelist's folder `dir`
  !> (resolve_input_paths); a fallback to the working directory is noted in cfg%path_note.
  function resolved_input(dir, name, what, cfg) result(p)
    character(len=*), intent(in) :: dir, name, what
    type(run_config_t), intent(inout) :: cfg
    character(len=:), allocatable :: p
    character(len=:), allocatable :: note
    p = name
    if (len(name) == 0) return
    if (name(1:1) == '/') return
    p = dir // name
    if (input_exists(p) .or. .not. input_exists(name)) return
    p = name
    note = what // ' = ''' // name // ''' is not found relative to the namelist''s folder (''' // dir // name // &
      '''): read relative to the working directory instead; expected a path relative to the namelist file'
    if (allocated(cfg%path_note)) then
      if (len(cfg%path_note) > 0) note = cfg%path_note // '; ' // note
    end if
    cfg%path_note = note
  end function resolved_input

  !> True when an input file (or, for a Triangle base name, its .node, .ele or .poly file)
  !> exists.
  logical function input_exists(name)
    character(len=*), intent(in) :: name
    logical :: e
    integer :: k
    character(len=5), parameter :: ext(4) = [character(len=5) :: '', '.node', '.ele', '.poly']
    input_exists = .false.
    do k = 1, size(ext)
      inquire (file=name // trim(ext(k)), exist=e)
      if (e) then
        input_exists = .true.
        return
      end if
    end do
  end function input_exists

  !> The resolved configuration as namelist text (for the header of a table): lines of at
  !> least 300 characters, longer when an expression of &problem needs it.  Read back, the
  !> text gives the same configuration (with &problem, &run names no scene).
  function config_echo(cfg) result(lines)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: lines(:)
    character(len=300) :: fixed(6)
    character(len=:), allocatable :: prob
    integer :: n, k, w
    fixed = ''
    fixed(1) = '&run title = ''' // trim(cfg%title) // ''''
    if (.not. cfg%has_problem) fixed(1) = trim(fixed(1)) // ', scene = ''' // trim(cfg%scene) // ''''
    fixed(1) = trim(fixed(1)) // ', output = ''' // trim(cfg%output) // ''', gamma_u_markers = ' // &
      ilist(cfg%gamma_u_markers) // ', gamma_a_markers = ' // ilist(cfg%gamma_a_markers) // ', vtk = ' // &
      ltoa(cfg%vtk) // ', latex = ' // ltoa(cfg%latex)
    if (cfg%vtk) fixed(1) = trim(fixed(1)) // ', vtu_format = ''' // trim(cfg%vtu_format) // ''''
    ! (given only: the default, the available memory, depends on the machine)
    if (cfg%max_memory_gb > 0.0_dp) fixed(1) = trim(fixed(1)) // ', max_memory_gb = ' // rtoa(cfg%max_memory_gb)
    n = 1
    if (any(cfg%gamma_u_names /= '') .or. any(cfg%gamma_a_names /= '')) then
      ! the names continue the &run group on a line of their own
      n = 2
      fixed(2) = '     gamma_u_names = ' // slist(cfg%gamma_u_names) // ', gamma_a_names = ' // &
        slist(cfg%gamma_a_names)
    end if
    fixed(n) = trim(fixed(n)) // ' /'
    fixed(n + 1) = '&mesh source = ''' // trim(cfg%mesh_source) // ''', file = ''' // trim(cfg%mesh_file) // &
      ''', format = ''' // trim(cfg%mesh_format) // ''', x0 = ' // rtoa(cfg%x0) // ', x1 = ' // rtoa(cfg%x1) // &
      ', y0 = ' // rtoa(cfg%y0) // &
      ', y1 = ' // rtoa(cfg%y1) // ', nx = ' // itoa(cfg%nx) // ', ny = ' // itoa(cfg%ny) // &
      ', n = ' // itoa(cfg%n) // ', pattern = ''' // trim(cfg%pattern) // ''', levels = ' // &
      itoa(cfg%levels) // ' /'
    fixed(n + 2) = '&solver method = ''' // trim(cfg%method) // ''', omega = ' // rtoa(cfg%omega) // &
      ', omega_auto = ' // ltoa(cfg%omega_auto) // ', tol = ' // rtoa(cfg%tol) // ', max_iter = ' // &
      itoa(cfg%max_iter) // ', check_every = ' // itoa(cfg%check_every) // ', nested = ' // &
      ltoa(cfg%nested) // ' /'
    fixed(n + 3) = '&dual enabled = ' // ltoa(cfg%dual_enabled) // ', method = ''' // trim(cfg%dual_method) // &
      ''', rho = ' // rtoa(cfg%dual_rho) // ', tol = ' // rtoa(cfg%dual_tol) // ', tol_h2 = ' // &
      rtoa(cfg%dual_tol_h2) // ', max_iter = ' // itoa(cfg%dual_max_iter) // ', ordering = ''' // &
      trim(cfg%dual_ordering) // ''', inner = ''' // trim(cfg%dual_inner) // ''', particular = ''' // &
      trim(cfg%dual_particular) // ''', space = ''' // trim(cfg%dual_space) // ''', algebraic_share = ' // &
      rtoa(cfg%dual_algebraic_share) // ' /'
    n = n + 3
    if (cfg%adapt_enabled) then
      fixed(n + 1) = '&adapt enabled = .true., theta = ' // rtoa(cfg%adapt_theta) // ', tol = ' // &
        rtoa(cfg%adapt_tol) // ', max_ndof = ' // itoa(cfg%adapt_max_ndof) // ', max_seconds = ' // &
        rtoa(cfg%adapt_max_seconds) // ', min_growth = ' // rtoa(cfg%adapt_min_growth) // &
        ', algebraic_share = ' // rtoa(cfg%adapt_algebraic_share) // ' /'
      n = n + 1
    end if
    prob = ''
    if (cfg%has_problem) prob = problem_echo(cfg)
    w = max(len(fixed), len(prob))
    allocate (character(len=w) :: lines(n + merge(1, 0, cfg%has_problem)))  ! small: a few lines of one run
    do k = 1, n
      lines(k) = fixed(k)
    end do
    if (cfg%has_problem) lines(n + 1) = prob
  end function config_echo

  !> The &problem group of cfg as one line of namelist text.
  function problem_echo(cfg) result(s)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: s
    integer :: k
    s = '&problem kind = ''' // trim(cfg%problem_kind) // ''''
    if (len_trim(config_text(cfg%f)) > 0) s = s // ', f = ''' // trim(config_text(cfg%f)) // ''''
    if (any(cfg%f_regions /= '')) s = s // ', f_regions = ' // slist(cfg%f_regions) // &
      ', f_region_values = ' // slist(cfg%f_region_values)
    if (len_trim(config_text(cfg%f_file)) > 0) s = s // ', f_file = ''' // trim(config_text(cfg%f_file)) // ''''
    if (len_trim(config_text(cfg%u_exact)) > 0) s = s // ', u_exact = ''' // trim(config_text(cfg%u_exact)) // ''''
    if (cfg%nbreaks > 0) then
      s = s // ', breaks = '
      do k = 1, cfg%nbreaks
        if (k > 1) s = s // ', '
        s = s // rtoa(cfg%breaks(k))
      end do
    end if
    s = s // ' /'
  end function problem_echo

  !> The text of an optional string of the configuration ('' when it was not given).
  pure function config_text(text) result(s)
    character(len=:), allocatable, intent(in) :: text
    character(len=:), allocatable :: s
    if (allocated(text)) then
      s = text
    else
      s = ''
    end if
  end function config_text

  ! ================================================================== reading
  !> All lines of a text file, each a string of its own length (at most max_line_len).
  subroutine read_lines(path, lines, st)
    character(len=*), intent(in) :: path
    type(text_line_t), allocatable, intent(out) :: lines(:)
    type(status_t), intent(out) :: st
    type(text_line_t), allocatable :: grown(:)
    character(len=read_chunk) :: buf
    character(len=:), allocatable :: cur
    character(len=256) :: msg
    integer :: u, ios, n, sz, k, ist
    integer(i8) :: nbytes
    logical :: there, at_end
    inquire (file=path, exist=there)
    if (.not. there) then
      call set_error(st, DS_ERR_IO, trim(path) // ': namelist file not found')
      return
    end if
    ! a FIFO would block the open for ever, a device or directory is no namelist file
    if (.not. input_file_ok(trim(path), trim(path) // ': ', 'a namelist file', nbytes, st)) return
    open (newunit=u, file=path, status='old', action='read', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, trim(path) // ': cannot open: ' // trim(msg))
      return
    end if
    allocate (lines(64))                            ! small: fixed size
    n = 0
    at_end = .false.
    do while (.not. at_end)
      cur = ''
      do                                   ! the line, read_chunk characters at a time
        read (u, '(a)', iostat=ios, size=sz, advance='no') buf
        if (is_iostat_end(ios)) then
          at_end = .true.
          exit
        end if
        if (ios /= 0 .and. .not. is_iostat_eor(ios)) then
          call set_error(st, DS_ERR_IO, trim(path) // ': read error after line ' // itoa(n))
          close (u)
          return
        end if
        if (len(cur) + sz > max_line_len) then
          call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(n + 1) // &
            ' is longer than ' // itoa(max_line_len) // ' characters (expected shorter lines: a long ' // &
            'list of values may continue on the next lines)')
          close (u)
          return
        end if
        cur = cur // buf(1:sz)
        if (is_iostat_eor(ios)) exit
      end do
      if (at_end .and. len(cur) == 0) exit
      n = n + 1
      if (n > size(lines)) then
        allocate (grown(2 * size(lines)), stat=ist)
        if (alloc_failed(ist, st, 'the lines of ' // trim(path), 2 * size(lines), storage_size(grown) / 8)) then
          close (u)
          return
        end if
        do k = 1, n - 1
          call move_alloc(lines(k)%s, grown(k)%s)
        end do
        call move_alloc(grown, lines)
      end if
      call move_alloc(cur, lines(n)%s)
    end do
    close (u)
    allocate (grown(n), stat=ist)
    if (alloc_failed(ist, st, 'the lines of ' // trim(path), n, storage_size(grown) / 8)) return
    do k = 1, n
      call move_alloc(lines(k)%s, grown(k)%s)
    end do
    call move_alloc(grown, lines)
  end subroutine read_lines

  !> Split the file into namelist groups: '&name' ... '/' (quote-aware; '!' comments).
  !> Text outside a group other than blanks and comments is an error.
  subroutine split_groups(path, lines, groups, st)
    character(len=*), intent(in) :: path
    type(text_line_t), intent(in) :: lines(:)
    type(group_t), allocatable, intent(out) :: groups(:)
    type(status_t), intent(out) :: st
    integer :: i, k, g, ng, name_end, nbody, ist
    integer, allocatable :: owner(:)       ! group of each kept line's body text
    integer, allocatable :: body_line(:)   ! its line
    type(text_line_t), allocatable :: body(:)
    character(len=32), allocatable :: gname(:)
    integer, allocatable :: gline(:)
    logical :: inside
    character(len=1) :: quote
    character(len=:), allocatable :: cur, rest
    inside = .false.
    ng = 0
    nbody = 0
    allocate (owner(16), body_line(16), body(16), gname(0), gline(0))  ! small: fixed size
    do i = 1, size(lines)
      cur = namelist_line(lines(i)%s, i) // ' '  ! (a blank after the end: scans may look one past it)
      k = 1
      if (inside .and. starts_group(cur)) then
        ! a new group before the '/' of the open one: name the open group, not a variable
        call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(gname(ng)) // ' group of line ' // &
          itoa(gline(ng)) // ' is not closed by ''/'' (line ' // itoa(i) // ' starts another group; expected ' // &
          'a ''/'' at the end of the &' // trim(gname(ng)) // ' group)')
        allocate (groups(0))                        ! small: empty
        return
      end if
      if (.not. inside) then
        k = verify(cur, ' ' // achar(9))
        if (k == 0) cycle
        if (cur(k:k) == '!') cycle
        if (cur(k:k) /= '&') then
          call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(i) // &
            ': expected the start of a namelist group (&run, &mesh, &solver, &dual, &problem or &adapt), found "' // &
            trim(cur(k:min(len_trim(cur), k + 30))) // '"')
          allocate (groups(0))                      ! small: empty
          return
        end if
        name_end = k + 1
        do while (name_end <= len_trim(cur))
          if (.not. is_ident_char(cur(name_end:name_end))) exit
          name_end = name_end + 1
        end do
        ng = ng + 1
        gname = [character(len=32) :: gname, lower(cur(k + 1:name_end - 1))]
        gline = [gline, i]
        inside = .true.
        cur(1:name_end - 1) = ' '
        k = name_end
      end if
      ! inside a group: keep characters up to a comment or the closing '/'
      quote = ' '
      do while (k <= len_trim(cur))
        if (quote /= ' ') then
          if (cur(k:k) == quote) quote = ' '
        else if (cur(k:k) == '''' .or. cur(k:k) == '"') then
          quote = cur(k:k)
        else if (cur(k:k) == '!') then
          cur = cur(1:k - 1)
          exit
        else if (cur(k:k) == '/') then
          ! after the '/' only blanks or a comment: text there is outside every group (a
          ! Fortran READ would skip it silently, a second group on the line included)
          rest = adjustl(cur(k + 1:))
          if (len_trim(rest) > 0 .and. rest(1:1) /= '!') then
            call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(i) // ': "' // &
              trim(rest(1:min(len_trim(rest), 30))) // '" after the ''/'' that closes the &' // trim(gname(ng)) // &
              ' group (expected nothing but a comment there; start the next group on a new line' // &
              slash_hint(cur, k) // ')')
            allocate (groups(0))                    ! small: empty
            return
          end if
          cur = cur(1:k - 1)
          inside = .false.
          exit
        end if
        k = k + 1
      end do
      if (quote /= ' ') then
        call set_error(st, DS_ERR_INPUT, trim(path) // ': line ' // itoa(i) // ': unterminated string')
        allocate (groups(0))                        ! small: empty
        return
      end if
      if (len_trim(cur) > 0) then
        nbody = nbody + 1
        if (nbody > size(owner)) then
          call grow_body()
          if (.not. is_ok(st)) return
        end if
        owner(nbody) = ng
        body_line(nbody) = i
        body(nbody)%s = trim(cur)
      end if
    end do
    allocate (groups(ng), stat=ist)
    if (alloc_failed(ist, st, 'the groups of ' // trim(path), ng, storage_size(groups) / 8)) return
    do g = 1, ng
      groups(g)%name = gname(g)
      groups(g)%line = gline(g)
      groups(g)%text_line = pack(body_line(1:nbody), owner(1:nbody) == g)
      allocate (groups(g)%text(size(groups(g)%text_line)), stat=ist)
      if (alloc_failed(ist, st, 'the text of a group of ' // trim(path), size(groups(g)%text_line), &
                       storage_size(groups(g)%text) / 8)) return
      k = 0
      do i = 1, nbody
        if (owner(i) /= g) cycle
        k = k + 1
        call move_alloc(body(i)%s, groups(g)%text(k)%s)
      end do
    end do
    if (inside) then
      call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(gname(ng)) // ' group of line ' // &
        itoa(gline(ng)) // ' is not closed by ''/'' (expected a ''/'' at its end)')
    end if
  contains
    !> Double the capacity of the body lists.
    subroutine grow_body()
      type(text_line_t), allocatable :: b2(:)
      integer :: j
      allocate (b2(2 * size(body)), stat=ist)
      if (alloc_failed(ist, st, 'the text of ' // trim(path), 2 * size(body), storage_size(b2) / 8)) return
      do j = 1, size(body)
        call move_alloc(body(j)%s, b2(j)%s)
      end do
      call move_alloc(b2, body)
      owner = [owner, owner]
      body_line = [body_line, body_line]
    end subroutine grow_body
  end subroutine split_groups

  !> When the '/' at cur(k:k) ends a word that follows '=' (output = out/run), the hint that
  !> a '/' inside a value must be quoted, with the value quoted; '' otherwise.
  pure function slash_hint(cur, k) result(hint)
    character(len=*), intent(in) :: cur
    integer, intent(in) :: k
    character(len=:), allocatable :: hint
    integer :: b, e
    hint = ''
    if (k < 2) return
    if (index(' ,=', cur(k - 1:k - 1)) > 0) return
    b = k - 1
    do while (b > 1)
      if (index(' ,=', cur(b - 1:b - 1)) > 0) exit
      b = b - 1
    end do
    if (b < 2) return
    if (adjustl(cur(1:b - 1)) == '') return
    if (cur(len_trim(cur(1:b - 1)):len_trim(cur(1:b - 1))) /= '=') return
    e = k + 1
    do while (e <= len_trim(cur))
      if (index(' ,/', cur(e:e)) > 0) exit
      e = e + 1
    end do
    hint = "; or, if the '/' belongs to a value such as a path, quote the value: '" // cur(b:e - 1) // "'"
  end function slash_hint

  !> Line i of a namelist file as the group reader sees it: a UTF-8 byte order mark at the
  !> start of the file dropped, tabs read as blanks (both are common in edited files).
  pure function namelist_line(line, i) result(cur)
    character(len=*), intent(in) :: line
    integer, intent(in) :: i
    character(len=len(line)) :: cur
    character(len=3), parameter :: bom = char(239) // char(187) // char(191)   ! EF BB BF
    integer :: k
    cur = line
    if (i == 1 .and. len(line) >= 3) then
      if (line(1:3) == bom) cur = line(4:)
    end if
    do k = 1, len_trim(cur)
      if (cur(k:k) == achar(9)) cur(k:k) = ' '
    end do
  end function namelist_line

  !> True when the line starts a namelist group: '&' and a letter after optional blanks.
  pure logical function starts_group(line)
    character(len=*), intent(in) :: line
    integer :: k
    starts_group = .false.
    k = verify(line, ' ')
    if (k == 0 .or. k >= len(line)) return
    starts_group = line(k:k) == '&' .and. is_ident_start(line(k + 1:k + 1))
  end function starts_group

  !> Check the variable names of a group, then read it into cfg.
  subroutine apply_group(path, grp, items, cfg, st)
    character(len=*), intent(in) :: path
    type(group_t), intent(in) :: grp
    character(len=*), intent(in) :: items
    type(run_config_t), intent(inout) :: cfg
    type(status_t), intent(out) :: st
    type(text_line_t), allocatable :: assign_text(:)
    character(len=:), allocatable :: assign(:), one(:)
    integer, allocatable :: assign_line(:)
    character(len=64) :: name
    character(len=256) :: msg
    integer :: a, b, ios, width, ist
    type(run_config_t) :: probe
    call split_assignments(grp, assign_text, assign_line, st)
    if (st%code /= 0) then
      st%msg = trim(path) // ': ' // st%msg
      return
    end if
    ! as an array of strings of the group's longest assignment (not of the longest line)
    width = 1
    do a = 1, size(assign_text)
      width = max(width, len(assign_text(a)%s))
    end do
    allocate (character(len=width) :: assign(size(assign_text)), stat=ist)
    if (alloc_failed(ist, st, 'the assignments of a group of ' // trim(path), size(assign_text), width)) return
    do a = 1, size(assign_text)
      assign(a) = assign_text(a)%s
    end do
    do a = 1, size(assign)
      name = assignment_name(assign(a))
      if (index(' ' // items // ' ', ' ' // trim(name) // ' ') == 0) then
        call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(grp%name) // ', line ' // &
          itoa(assign_line(a)) // ': unknown variable "' // trim(name) // '"' // did_you_mean(name, items, '') // &
          '; expected one of: ' // items)
        return
      end if
      do b = 1, a - 1
        if (assignment_target(assign(b)) /= assignment_target(assign(a))) cycle
        call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(grp%name) // ', line ' // &
          itoa(assign_line(a)) // ': "' // assignment_target(assign(a)) // '" is given twice (also on line ' // &
          itoa(assign_line(b)) // '; expected each variable once per group)')
        return
      end do
      if (grp%name == 'run' .and. name == 'scene') cfg%scene_given = .true.
    end do
    call read_group(grp%name, assign, cfg, ios, msg)
    if (ios == 0) return
    ! find the assignment whose value does not read (one at a time, copied: gfortran 12
    ! passes a section of a deferred-length array to an assumed-length dummy wrongly)
    allocate (character(len=width) :: one(1))      ! small: one assignment
    do a = 1, size(assign)
      probe = cfg
      one(1) = assign(a)
      call read_group(grp%name, one, probe, ios, msg)
      if (ios /= 0) then
        name = assignment_name(assign(a))
        ! the reader's own check says what it expected (bad_value), else the item's type
        if (index(msg, 'expected ') /= 1) msg = 'expected ' // expected_type(name)
        call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(grp%name) // ', line ' // &
          itoa(assign_line(a)) // ': invalid value for "' // trim(name) // '" (' // trim(msg) // ')')
        return
      end if
    end do
    call set_error(st, DS_ERR_INPUT, trim(path) // ': &' // trim(grp%name) // ', line ' // &
      itoa(grp%line) // ': ' // trim(msg))
  end subroutine apply_group

  !> Split a group's text into assignments "name = value[, value...]", each starting at an
  !> identifier followed (after an optional subscript) by '=' outside quotes.
  subroutine split_assignments(grp, assign, assign_line, st)
    type(group_t), intent(in) :: grp
    type(text_line_t), allocatable, intent(out) :: assign(:)
    integer, allocatable, intent(out) :: assign_line(:)
    type(status_t), intent(out) :: st
    integer :: t, k, j, n, depth
    character(len=1) :: quote
    character(len=:), allocatable :: cur
    allocate (assign(0), assign_line(0))            ! small: empty
    n = 0
    do t = 1, size(grp%text)
      cur = grp%text(t)%s // ' '          ! (a blank after the end: scans may look one past it)
      quote = ' '
      k = 1
      do while (k <= len_trim(cur))
        if (quote /= ' ') then
          if (cur(k:k) == quote) quote = ' '
          k = k + 1
          cycle
        end if
        if (cur(k:k) == '''' .or. cur(k:k) == '"') then
          quote = cur(k:k)
        else if (is_ident_start(cur(k:k)) .and. starts_token(cur, k)) then
          ! identifier: is it followed by '=' (optionally after a subscript)?
          j = k
          do while (j <= len_trim(cur))
            if (.not. is_ident_char(cur(j:j))) exit
            j = j + 1
          end do
          j = skip_blanks(cur, j)
          if (j <= len_trim(cur) .and. cur(j:j) == '(') then
            depth = 0
            do while (j <= len_trim(cur))
              if (cur(j:j) == '(') depth = depth + 1
              if (cur(j:j) == ')') depth = depth - 1
              j = j + 1
              if (depth == 0) exit
            end do
            j = skip_blanks(cur, j)
          end if
          if (j <= len_trim(cur) .and. cur(j:j) == '=') then
            n = n + 1
            call append_text(assign, cur(k:), st)
            if (.not. is_ok(st)) return
            assign_line = [assign_line, grp%text_line(t)]
            if (n > 1) then
              if (assign_line(n - 1) == assign_line(n)) call cut_previous(assign(n - 1)%s, cur(k:))
            end if
            k = j + 1
            cycle
          end if
          k = j
          cycle
        end if
        k = k + 1
      end do
      if (n == 0) then
        call set_error(st, DS_ERR_INPUT, '&' // trim(grp%name) // ', line ' // itoa(grp%text_line(t)) // &
          ': expected "name = value", found "' // trim(cur) // '"')
        return
      end if
    end do
    ! glue continuation lines (lines without an assignment) to the previous assignment
    call glue_continuations(grp, assign, assign_line)
  end subroutine split_assignments

  !> Append a copy of `text` to the list `list` (element by element: gfortran 12 mishandles
  !> some array constructors of derived types with deferred-length components).
  subroutine append_text(list, text, st)
    type(text_line_t), allocatable, intent(inout) :: list(:)
    character(len=*), intent(in) :: text
    type(status_t), intent(inout) :: st
    type(text_line_t), allocatable :: grown(:)
    integer :: j, ist
    allocate (grown(size(list) + 1), stat=ist)
    if (alloc_failed(ist, st, 'the assignments of a group', size(list) + 1, storage_size(grown) / 8)) return
    do j = 1, size(list)
      call move_alloc(list(j)%s, grown(j)%s)
    end do
    grown(size(grown))%s = text
    call move_alloc(grown, list)
  end subroutine append_text

  !> Remove from `prev` the text of the following assignment `next` (same line).
  pure subroutine cut_previous(prev, next)
    character(len=:), allocatable, intent(inout) :: prev
    character(len=*), intent(in) :: next
    integer :: k
    k = index(prev, trim(next), back=.true.)
    if (k > 1) prev = prev(1:k - 1)
  end subroutine cut_previous

  !> Lines of a group that contain no assignment continue the value list of the previous one.
  subroutine glue_continuations(grp, assign, assign_line)
    type(group_t), intent(in) :: grp
    type(text_line_t), intent(inout) :: assign(:)
    integer, intent(in) :: assign_line(:)
    integer :: t, a
    do t = 1, size(grp%text)
      if (any(assign_line == grp%text_line(t))) cycle
      do a = size(assign), 1, -1
        if (assign_line(a) < grp%text_line(t)) then
          assign(a)%s = trim(assign(a)%s) // ' ' // trim(adjustl(grp%text(t)%s))
          exit
        end if
      end do
    end do
  end subroutine glue_continuations

  !> Read the assignments of group `gname` into cfg with a real namelist read.
  subroutine read_group(gname, assign, cfg, ios, msg)
    character(len=*), intent(in) :: gname
    character(len=*), intent(in) :: assign(:)
    type(run_config_t), intent(inout) :: cfg
    integer, intent(out) :: ios
    character(len=*), intent(out) :: msg
    character(len=len(assign) + 16) :: rec(size(assign) + 2)
    ! &run
    character(len=wide) :: title
    character(len=wide) :: scene
    character(len=wide) :: output
    integer :: gamma_u_markers(max_markers), gamma_a_markers(max_markers)
    logical :: vtk, latex
    character(len=wide) :: vtu_format
    character(len=wide) :: gamma_u_names(max_markers), gamma_a_names(max_markers)
    real(dp) :: max_memory_gb
    ! &mesh
    character(len=wide) :: source, pattern
    character(len=wide) :: file, format
    real(dp) :: x0, x1, y0, y1
    integer :: nx, ny, n, levels
    ! &solver
    character(len=wide) :: method
    real(dp) :: omega, tol
    logical :: omega_auto, nested
    integer :: max_iter, check_every
    namelist /run/ title, scene, output, gamma_u_markers, gamma_a_markers, vtk, vtu_format, latex, gamma_u_names, &
                   gamma_a_names, max_memory_gb
    namelist /mesh/ source, file, format, x0, x1, y0, y1, nx, ny, n, pattern, levels
    namelist /solver/ method, omega, omega_auto, tol, max_iter, check_every, nested
    integer :: k
    logical :: saved_halting(size(ieee_usual))

    if (gname == 'dual') then
      call read_dual_group(assign, cfg, ios, msg)
      return
    else if (gname == 'problem') then
      call read_problem_group(assign, cfg, ios, msg)
      return
    else if (gname == 'adapt') then
      call read_adapt_group(assign, cfg, ios, msg)
      return
    end if

    rec(1) = '&' // gname
    do k = 1, size(assign)
      rec(k + 1) = assign(k)
    end do
    rec(size(rec)) = '/'
    msg = ''
    ios = 0
    select case (gname)
    case ('run')
      title = cfg%title
      scene = cfg%scene
      output = cfg%output
      ! unset slots hold unset_marker while reading: a 0 given inside a list is then seen
      gamma_u_markers = merge(unset_marker, cfg%gamma_u_markers, cfg%gamma_u_markers == 0)
      gamma_a_markers = merge(unset_marker, cfg%gamma_a_markers, cfg%gamma_a_markers == 0)
      vtk = cfg%vtk
      vtu_format = cfg%vtu_format
      latex = cfg%latex
      gamma_u_names = cfg%gamma_u_names
      gamma_a_names = cfg%gamma_a_names
      max_memory_gb = cfg%max_memory_gb
      call fp_traps_off(saved_halting)
      read (rec, nml=run, iostat=ios, iomsg=msg)
      call ieee_set_halting_mode(ieee_usual, saved_halting)
      if (ios /= 0) return
      if (.not. ieee_is_finite(max_memory_gb)) then
        call bad_value('a finite real number', ios, msg)
        return
      end if
      if (zero_in_list(gamma_u_markers) .or. zero_in_list(gamma_a_markers)) then
        call bad_value('a list of at most 16 integers > 0; 0 alone is the empty list', ios, msg)
        return
      end if
      gamma_u_markers = merge(0, gamma_u_markers, gamma_u_markers == unset_marker)
      gamma_a_markers = merge(0, gamma_a_markers, gamma_a_markers == unset_marker)
      call check_len(title, cfg%title, ios, msg)
      call check_len(scene, cfg%scene, ios, msg)
      call check_len(output, cfg%output, ios, msg)
      call check_len(vtu_format, cfg%vtu_format, ios, msg)
      if (ios /= 0) return
      do k = 1, max_markers
        if (too_long(gamma_u_names(k), cfg%gamma_u_names(k)) .or. too_long(gamma_a_names(k), cfg%gamma_a_names(k))) then
          call bad_value('quoted names of at most ' // itoa(marker_name_len) // ' characters', ios, msg)
          return
        end if
      end do
      do k = 1, max_markers
        cfg%gamma_u_names(k) = gamma_u_names(k)(1:marker_name_len)
        cfg%gamma_a_names(k) = gamma_a_names(k)(1:marker_name_len)
      end do
      cfg%title = title(1:len(cfg%title))
      cfg%scene = scene(1:len(cfg%scene))
      cfg%output = output(1:len(cfg%output))
      cfg%gamma_u_markers = gamma_u_markers
      cfg%gamma_a_markers = gamma_a_markers
      cfg%vtk = vtk
      cfg%vtu_format = vtu_format(1:len(cfg%vtu_format))
      cfg%latex = latex
      cfg%max_memory_gb = max_memory_gb
    case ('mesh')
      source = cfg%mesh_source
      file = cfg%mesh_file
      format = cfg%mesh_format
      x0 = cfg%x0
      x1 = cfg%x1
      y0 = cfg%y0
      y1 = cfg%y1
      nx = cfg%nx
      ny = cfg%ny
      n = cfg%n
      pattern = cfg%pattern
      levels = cfg%levels
      call fp_traps_off(saved_halting)
      read (rec, nml=mesh, iostat=ios, iomsg=msg)
      call ieee_set_halting_mode(ieee_usual, saved_halting)
      if (ios /= 0) return
      if (.not. all(ieee_is_finite([x0, x1, y0, y1]))) then
        call bad_value('a finite real number', ios, msg)
        return
      end if
      call check_len(source, cfg%mesh_source, ios, msg)
      call check_len(pattern, cfg%pattern, ios, msg)
      call check_len(file, cfg%mesh_file, ios, msg)
      call check_len(format, cfg%mesh_format, ios, msg)
      if (ios /= 0) return
      cfg%mesh_source = source(1:len(cfg%mesh_source))
      cfg%mesh_file = file(1:len(cfg%mesh_file))
      cfg%mesh_format = format(1:len(cfg%mesh_format))
      cfg%x0 = x0
      cfg%x1 = x1
      cfg%y0 = y0
      cfg%y1 = y1
      cfg%nx = nx
      cfg%ny = ny
      cfg%n = n
      cfg%pattern = pattern(1:len(cfg%pattern))
      cfg%levels = levels
    case ('solver')
      method = cfg%method
      omega = cfg%omega
      omega_auto = cfg%omega_auto
      tol = cfg%tol
      max_iter = cfg%max_iter
      check_every = cfg%check_every
      nested = cfg%nested
      call fp_traps_off(saved_halting)
      read (rec, nml=solver, iostat=ios, iomsg=msg)
      call ieee_set_halting_mode(ieee_usual, saved_halting)
      if (ios /= 0) return
      if (.not. all(ieee_is_finite([omega, tol]))) then
        call bad_value('a finite real number', ios, msg)
        return
      end if
      call check_len(method, cfg%method, ios, msg)
      if (ios /= 0) return
      cfg%method = method(1:len(cfg%method))
      cfg%omega = omega
      cfg%omega_auto = omega_auto
      cfg%tol = tol
      cfg%max_iter = max_iter
      cfg%check_every = check_every
      cfg%nested = nested
    end select
  end subroutine read_group

  !> Read the assignments of the &dual group into cfg (its names overlap &solver's).
  subroutine read_dual_group(assign, cfg, ios, msg)
    character(len=*), intent(in) :: assign(:)
    type(run_config_t), intent(inout) :: cfg
    integer, intent(out) :: ios
    character(len=*), intent(out) :: msg
    character(len=len(assign) + 16) :: rec(size(assign) + 2)
    logical :: enabled
    character(len=wide) :: method, ordering, inner, particular, space
    real(dp) :: rho, tol, tol_h2, algebraic_share
    integer :: max_iter, k
    namelist /dual/ enabled, method, rho, tol, tol_h2, max_iter, ordering, inner, particular, space, algebraic_share
    logical :: saved_halting(size(ieee_usual))
    rec(1) = '&dual'
    do k = 1, size(assign)
      rec(k + 1) = assign(k)
    end do
    rec(size(rec)) = '/'
    msg = ''
    enabled = cfg%dual_enabled
    method = cfg%dual_method
    rho = cfg%dual_rho
    tol = cfg%dual_tol
    tol_h2 = cfg%dual_tol_h2
    max_iter = cfg%dual_max_iter
    ordering = cfg%dual_ordering
    inner = cfg%dual_inner
    particular = cfg%dual_particular
    space = cfg%dual_space
    algebraic_share = cfg%dual_algebraic_share
    call fp_traps_off(saved_halting)
    read (rec, nml=dual, iostat=ios, iomsg=msg)
    call ieee_set_halting_mode(ieee_usual, saved_halting)
    if (ios /= 0) return
    if (.not. all(ieee_is_finite([rho, tol, tol_h2, algebraic_share]))) then
      call bad_value('a finite real number', ios, msg)
      return
    end if
    call check_len(method, cfg%dual_method, ios, msg)
    call check_len(ordering, cfg%dual_ordering, ios, msg)
    call check_len(inner, cfg%dual_inner, ios, msg)
    call check_len(particular, cfg%dual_particular, ios, msg)
    call check_len(space, cfg%dual_space, ios, msg)
    if (ios /= 0) return
    cfg%dual_enabled = enabled
    cfg%dual_method = method(1:len(cfg%dual_method))
    cfg%dual_rho = rho
    cfg%dual_tol = tol
    cfg%dual_tol_h2 = tol_h2
    cfg%dual_max_iter = max_iter
    cfg%dual_ordering = ordering(1:len(cfg%dual_ordering))
    cfg%dual_inner = inner(1:len(cfg%dual_inner))
    cfg%dual_particular = particular(1:len(cfg%dual_particular))
    cfg%dual_space = space(1:len(cfg%dual_space))
    cfg%dual_algebraic_share = algebraic_share
  end subroutine read_dual_group

  !> Read the assignments of the &adapt group into cfg.
  subroutine read_adapt_group(assign, cfg, ios, msg)
    character(len=*), intent(in) :: assign(:)
    type(run_config_t), intent(inout) :: cfg
    integer, intent(out) :: ios
    character(len=*), intent(out) :: msg
    character(len=len(assign) + 16) :: rec(size(assign) + 2)
    logical :: enabled
    real(dp) :: theta, tol, max_seconds, min_growth, algebraic_share
    integer :: max_ndof, k
    namelist /adapt/ enabled, theta, tol, max_ndof, max_seconds, min_growth, algebraic_share
    logical :: saved_halting(size(ieee_usual))
    rec(1) = '&adapt'
    do k = 1, size(assign)
      rec(k + 1) = assign(k)
    end do
    rec(size(rec)) = '/'
    msg = ''
    enabled = cfg%adapt_enabled
    theta = cfg%adapt_theta
    tol = cfg%adapt_tol
    max_ndof = cfg%adapt_max_ndof
    max_seconds = cfg%adapt_max_seconds
    min_growth = cfg%adapt_min_growth
    algebraic_share = cfg%adapt_algebraic_share
    call fp_traps_off(saved_halting)
    read (rec, nml=adapt, iostat=ios, iomsg=msg)
    call ieee_set_halting_mode(ieee_usual, saved_halting)
    if (ios /= 0) return
    if (.not. all(ieee_is_finite([theta, tol, max_seconds, min_growth, algebraic_share]))) then
      call bad_value('a finite real number', ios, msg)
      return
    end if
    cfg%adapt_enabled = enabled
    cfg%adapt_theta = theta
    cfg%adapt_tol = tol
    cfg%adapt_max_ndof = max_ndof
    cfg%adapt_max_seconds = max_seconds
    cfg%adapt_min_growth = min_growth
    cfg%adapt_algebraic_share = algebraic_share
  end subroutine read_adapt_group

  !> Range checks of the &adapt group (after validate's), each naming the variable.
  subroutine validate_adapt(cfg, where, st)
    type(run_config_t), intent(in) :: cfg
    character(len=*), intent(in) :: where
    type(status_t), intent(inout) :: st
    if (.not. (cfg%adapt_theta > 0.0_dp .and. cfg%adapt_theta <= 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt theta = ' // rtoa(cfg%adapt_theta) // &
        '; expected 0 < theta <= 1 (Doerfler: the marked indicators sum to at least theta est)')
    else if (.not. (cfg%adapt_tol >= 0.0_dp .and. cfg%adapt_tol < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt tol = ' // rtoa(cfg%adapt_tol) // &
        '; expected 0 <= tol < 1 (the certified relative error to reach; 0: none)')
    else if (cfg%adapt_max_ndof < 0) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt max_ndof = ' // itoa(cfg%adapt_max_ndof) // &
        '; expected >= 0 (0: no limit)')
    else if (.not. cfg%adapt_max_seconds >= 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt max_seconds = ' // rtoa(cfg%adapt_max_seconds) // &
        '; expected >= 0 (0: no limit)')
    else if (.not. (cfg%adapt_min_growth >= 1.0_dp .and. cfg%adapt_min_growth <= 2.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt min_growth = ' // rtoa(cfg%adapt_min_growth) // &
        '; expected 1 <= min_growth <= 2 (the growth of the unknowns each step at least adds; 1: Doerfler''s set alone)')
    else if (.not. (cfg%adapt_algebraic_share >= 0.0_dp .and. cfg%adapt_algebraic_share < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt algebraic_share = ' // rtoa(cfg%adapt_algebraic_share) // &
        '; expected 0 <= algebraic_share < 1 (the share of est the dual solve of a step may leave; 0: solve exactly)')
    else if (cfg%adapt_enabled .and. .not. cfg%dual_enabled) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt enabled = .true. needs &dual enabled = .true. ' // &
        '(the element indicators of the bound est drive the marking)')
    else if (cfg%adapt_enabled .and. cfg%adapt_tol == 0.0_dp .and. cfg%adapt_max_ndof == 0 .and. &
             cfg%adapt_max_seconds == 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, where // '&adapt enabled = .true. without tol, max_ndof or max_seconds; ' // &
        'expected at least one of them > 0 (when to stop)')
    end if
  end subroutine validate_adapt

  !> Read the assignments of the &problem group into cfg.  Its strings are read into
  !> variables as long as the assignments, so that no expression is cut.
  subroutine read_problem_group(assign, cfg, ios, msg)
    character(len=*), intent(in) :: assign(:)
    type(run_config_t), intent(inout) :: cfg
    integer, intent(out) :: ios
    character(len=*), intent(out) :: msg
    character(len=len(assign) + 16) :: rec(size(assign) + 2)
    character(len=len(assign)) :: f, u_exact, f_file
    character(len=wide) :: kind
    character(len=wide) :: f_regions(max_markers)
    character(len=max(wide, len(assign))) :: f_region_values(max_markers)
    real(dp) :: breaks(max_breaks)
    integer :: k
    namelist /problem/ kind, f, u_exact, breaks, f_regions, f_region_values, f_file
    logical :: saved_halting(size(ieee_usual))
    rec(1) = '&problem'
    do k = 1, size(assign)
      rec(k + 1) = assign(k)
    end do
    rec(size(rec)) = '/'
    msg = ''
    kind = cfg%problem_kind
    f = config_text(cfg%f)
    u_exact = config_text(cfg%u_exact)
    f_file = config_text(cfg%f_file)
    breaks = unset_break
    breaks(1:cfg%nbreaks) = cfg%breaks(1:cfg%nbreaks)
    f_regions = cfg%f_regions
    f_region_values = cfg%f_region_values
    call fp_traps_off(saved_halting)
    read (rec, nml=problem, iostat=ios, iomsg=msg)
    call ieee_set_halting_mode(ieee_usual, saved_halting)
    if (ios /= 0) return
    if (.not. all(ieee_is_finite(breaks))) then
      call bad_value('a finite real number', ios, msg)
      return
    end if
    call check_len(kind, cfg%problem_kind, ios, msg)
    if (ios /= 0) return
    do k = 1, max_markers
      if (too_long(f_regions(k), cfg%f_regions(k))) then
        call bad_value('quoted names of at most ' // itoa(marker_name_len) // ' characters', ios, msg)
        return
      end if
      if (too_long(f_region_values(k), cfg%f_region_values(k))) then
        call bad_value('expressions of at most ' // itoa(region_value_len) // ' characters', ios, msg)
        return
      end if
    end do
    cfg%problem_kind = kind(1:len(cfg%problem_kind))
    cfg%f = trim(f)
    cfg%u_exact = trim(u_exact)
    cfg%f_file = trim(f_file)
    cfg%nbreaks = count(breaks /= unset_break)
    cfg%breaks = 0.0_dp
    cfg%breaks(1:cfg%nbreaks) = pack(breaks, breaks /= unset_break)
    do k = 1, max_markers
      cfg%f_regions(k) = f_regions(k)(1:marker_name_len)
      cfg%f_region_values(k) = f_region_values(k)      ! (no longer: checked by too_long)
    end do
  end subroutine read_problem_group

  !> Checks of &problem: the kind, exactly one form of the load, no scene besides it,
  !> the expressions compile (a syntax error names the file, the variable and the column).
  subroutine validate_problem(cfg, st)
    type(run_config_t), intent(inout) :: cfg
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: where
    type(expression_t) :: e
    integer :: nforms, nreg, nval, k
    if (.not. cfg%has_problem) return
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': '
    cfg%problem_kind = upper2(cfg%problem_kind)
    nreg = count(cfg%f_regions /= '')
    nval = count(cfg%f_region_values /= '')
    nforms = count([len_trim(config_text(cfg%f)) > 0, nreg + nval > 0, len_trim(config_text(cfg%f_file)) > 0])
    if (cfg%scene_given) then
      call set_error(st, DS_ERR_INPUT, where // '&run scene = ''' // trim(cfg%scene) // ''' and &problem (line ' // &
        itoa(cfg%problem_line) // ') both describe the problem; expected either a scene of the catalogue ' // &
        '(&run scene) or one''s own problem (&problem), not both')
    else if (cfg%problem_kind /= 'P1' .and. cfg%problem_kind /= 'P2') then
      call set_error(st, DS_ERR_INPUT, where // '&problem kind = ''' // trim(cfg%problem_kind) // &
        '''; expected P1 (-Lap u + u = f, Signorini on Gamma_a) or P2 (-Lap u = f, u = 0 on Gamma_u)')
    else if (nforms /= 1) then
      call set_error(st, DS_ERR_INPUT, where // '&problem gives the load ' // itoa(nforms) // ' times; expected ' // &
        'exactly one of f (an expression), f_regions with f_region_values (per region), f_file (nodal values)')
    else if (nreg /= nval .or. any((cfg%f_regions == '') .neqv. (cfg%f_region_values == ''))) then
      call set_error(st, DS_ERR_INPUT, where // '&problem f_regions names ' // itoa(nreg) // &
        ' region(s) and f_region_values gives ' // itoa(nval) // ' value(s); expected one value per region, ' // &
        'in the same order')
    end if
    if (st%code /= 0) return
    if (len_trim(config_text(cfg%f)) > 0) then
      call expression_compile_input(trim(cfg%f), cfg%source_file, 'problem', 'f', e, st)
      if (st%code /= 0) return
    end if
    if (len_trim(config_text(cfg%u_exact)) > 0) then
      call expression_compile_input(trim(cfg%u_exact), cfg%source_file, 'problem', 'u_exact', e, st)
      if (st%code /= 0) return
    end if
    do k = 1, max_markers
      if (cfg%f_regions(k) == '') cycle
      call expression_compile_input(trim(cfg%f_region_values(k)), cfg%source_file, 'problem', &
        'f_region_values(' // itoa(k) // ')', e, st)
      if (st%code /= 0) then
        st%msg = st%msg // ' (the value of region ''' // trim(cfg%f_regions(k)) // ''')'
        return
      end if
    end do
  end subroutine validate_problem

  !> 'p1' -> 'P1'.
  pure function upper2(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: k
    t = s
    do k = 1, len(s)
      if (s(k:k) >= 'a' .and. s(k:k) <= 'z') t(k:k) = achar(iachar(s(k:k)) - 32)
    end do
  end function upper2

  !> Range checks of a run configuration, each naming the variable and what is expected.
  subroutine validate(cfg, st)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: where
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': '
    if (len_trim(cfg%output) == 0) then
      call set_error(st, DS_ERR_INPUT, where // '&run output must name the output files (no extension)')
    else if (cfg%output(len_trim(cfg%output):len_trim(cfg%output)) == '/' .or. names_directory(cfg%output)) then
      call set_error(st, DS_ERR_INPUT, where // '&run output = ''' // trim(cfg%output) // &
        ''' names a directory; expected a path of the table files without extension, e.g. ''out/run1''')
    else if (.not. any(cfg%vtu_format == [character(len=16) :: 'binary', 'ascii'])) then
      call set_error(st, DS_ERR_INPUT, where // '&run vtu_format = ''' // trim(cfg%vtu_format) // &
        '''; expected ''binary'' (zlib-compressed arrays, the default) or ''ascii'' (arrays as text)')
    else if (cfg%max_memory_gb < 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, where // '&run max_memory_gb = ' // rtoa(cfg%max_memory_gb) // &
        '; expected >= 0 (0: the available memory of the machine)')
    else if (any(cfg%gamma_u_markers < 0) .or. any(cfg%gamma_a_markers < 0)) then
      call set_error(st, DS_ERR_INPUT, where // '&run gamma_u_markers / gamma_a_markers must be > 0')
    else if (.not. any(cfg%mesh_source == [character(len=16) :: 'rectangle', 'lshape', 'holed_square', 'file'])) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh source = "' // trim(cfg%mesh_source) // &
        '"; expected rectangle, lshape, holed_square or file')
    else if (cfg%mesh_source == 'file' .and. len_trim(cfg%mesh_file) == 0) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh file must be given when source = ''file''')
    else if (cfg%mesh_source /= 'file' .and. len_trim(cfg%mesh_file) > 0) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh file = ''' // trim(cfg%mesh_file) // ''' is given but ' // &
        '&mesh source = ''' // trim(cfg%mesh_source) // '''; expected source = ''file'' to read the mesh file ' // &
        '(or no file for a generated mesh)')
    else if (.not. any(cfg%mesh_format == [character(len=16) :: 'auto', 'dualsig', 'gmsh', 'triangle'])) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh format = "' // trim(cfg%mesh_format) // &
        '"; expected auto, dualsig, gmsh or triangle')
    else if ((any(cfg%gamma_u_names /= '') .or. any(cfg%gamma_a_names /= '')) .and. &
             (any(cfg%gamma_u_markers /= 0) .or. any(cfg%gamma_a_markers /= 0))) then
      call set_error(st, DS_ERR_INPUT, where // '&run gamma_u_names / gamma_a_names and gamma_u_markers / ' // &
        'gamma_a_markers are mutually exclusive; expected the boundary parts either by name or by marker')
    else if ((any(cfg%gamma_u_names /= '') .or. any(cfg%gamma_a_names /= '')) .and. cfg%mesh_source /= 'file') then
      call set_error(st, DS_ERR_INPUT, where // '&run gamma_u_names / gamma_a_names name Gmsh physical ' // &
        'curves; expected &mesh source = ''file'' with a Gmsh mesh (source = ''' // trim(cfg%mesh_source) // &
        ''' has numbered markers only)')
    else if (cfg%levels < 1 .or. cfg%levels > max_levels) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh levels = ' // itoa(cfg%levels) // &
        '; expected 1 to ' // itoa(max_levels))
    else if (cfg%nx < 1 .or. cfg%ny < 1 .or. cfg%n < 1) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh nx, ny and n must be >= 1')
    else if (.not. (cfg%x1 > cfg%x0 .and. cfg%y1 > cfg%y0)) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh needs x0 < x1 and y0 < y1')
    else if (.not. any(cfg%pattern == [character(len=16) :: 'right', 'left', 'union_jack'])) then
      call set_error(st, DS_ERR_INPUT, where // '&mesh pattern = "' // trim(cfg%pattern) // &
        '"; expected right, left or union_jack')
    else if (.not. any(cfg%method == [character(len=16) :: 'psor', 'active_set', 'schur', 'auto', 'multigrid'])) then
      call set_error(st, DS_ERR_INPUT, where // '&solver method = "' // trim(cfg%method) // &
        '"; expected psor, active_set, schur, auto or multigrid')
    else if (.not. (cfg%omega > 0.0_dp .and. cfg%omega < 2.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&solver omega = ' // rtoa(cfg%omega) // &
        '; expected 0 < omega < 2')
    else if (.not. (cfg%tol > 0.0_dp .and. cfg%tol < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&solver tol = ' // rtoa(cfg%tol) // &
        '; expected 0 < tol < 1')
    else if (cfg%max_iter < 1) then
      call set_error(st, DS_ERR_INPUT, where // '&solver max_iter must be >= 1')
    else if (cfg%check_every < 1) then
      call set_error(st, DS_ERR_INPUT, where // '&solver check_every must be >= 1')
    else if (.not. any(cfg%dual_method == [character(len=16) :: 'default', 'active_set', 'augmented', 'uzawa', &
                                            'nested', 'multigrid'])) then
      call set_error(st, DS_ERR_INPUT, where // '&dual method = "' // trim(cfg%dual_method) // &
        '"; expected default, active_set (P1), nested (P1, space hdiv), augmented (P2), multigrid (P2) or uzawa')
    else if (.not. cfg%dual_rho >= 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, where // '&dual rho = ' // rtoa(cfg%dual_rho) // &
        '; expected rho > 0, or 0 for the automatic choice')
    else if (.not. (cfg%dual_tol > 0.0_dp .and. cfg%dual_tol < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&dual tol = ' // rtoa(cfg%dual_tol) // '; expected 0 < tol < 1')
    else if (.not. (cfg%dual_tol_h2 >= 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&dual tol_h2 must be >= 0')
    else if (cfg%dual_max_iter < 1) then
      call set_error(st, DS_ERR_INPUT, where // '&dual max_iter must be >= 1')
    else if (.not. any(cfg%dual_ordering == [character(len=16) :: 'nd', 'best', 'amd', 'metis', 'natural'])) then
      call set_error(st, DS_ERR_INPUT, where // '&dual ordering = "' // trim(cfg%dual_ordering) // &
        '"; expected nd, best, amd, metis or natural')
    else if (.not. any(cfg%dual_inner == [character(len=16) :: 'schur', 'active_set'])) then
      call set_error(st, DS_ERR_INPUT, where // '&dual inner = "' // trim(cfg%dual_inner) // &
        '"; expected schur or active_set')
    else if (.not. any(cfg%dual_particular == [character(len=16) :: 'polynomial', 'stream'])) then
      call set_error(st, DS_ERR_INPUT, where // '&dual particular = "' // trim(cfg%dual_particular) // &
        '"; expected polynomial (certified for any f) or stream (the paper''s lambda_bar + curl omega)')
    else if (.not. any(cfg%dual_space == [character(len=16) :: 'hdiv', 'paper'])) then
      call set_error(st, DS_ERR_INPUT, where // '&dual space = "' // trim(cfg%dual_space) // &
        '"; expected hdiv (Raviart-Thomas of order 1, the default) or paper (the continuous P1 fields of Section 3)')
    else if (.not. (cfg%dual_algebraic_share >= 0.0_dp .and. cfg%dual_algebraic_share < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, where // '&dual algebraic_share = ' // rtoa(cfg%dual_algebraic_share) // &
        '; expected 0 <= algebraic_share < 1 (the share of est the dual solve of a level may leave; 0: solve exactly)')
    end if
    if (st%code == 0) call validate_adapt(cfg, where, st)
  end subroutine validate

  ! ================================================================== small helpers
  !> True when the output name is '.' or '..' (as its last component) or an existing
  !> directory: the tables would be hidden files '<dir>/.txt'.
  logical function names_directory(output)
    character(len=*), intent(in) :: output
    character(len=:), allocatable :: base, why
    integer(i8) :: nbytes
    integer :: k
    k = index(trim(output), '/', back=.true.)
    base = trim(output(k + 1:))
    names_directory = base == '.' .or. base == '..'
    if (.not. names_directory) names_directory = .not. regular_file_size(trim(output), nbytes, why) .and. &
      why == 'a directory'
  end function names_directory

  !> Remember the halting modes of the usual IEEE exceptions and disarm them: a namelist
  !> value such as 1e999 must give an error message, not a floating-point trap.
  subroutine fp_traps_off(saved)
    logical, intent(out) :: saved(:)
    call ieee_get_halting_mode(ieee_usual, saved)
    call ieee_set_halting_mode(ieee_usual, .false.)
  end subroutine fp_traps_off

  !> True when the value read does not fit the configuration field.
  pure logical function too_long(value, field)
    character(len=*), intent(in) :: value, field
    too_long = len_trim(value) > len(field)
  end function too_long

  !> Unless a check failed already (ios /= 0): fail when value does not fit in field,
  !> naming both lengths.
  subroutine check_len(value, field, ios, msg)
    character(len=*), intent(in) :: value, field
    integer, intent(inout) :: ios
    character(len=*), intent(inout) :: msg
    if (ios /= 0) return
    if (too_long(value, field)) call bad_value('a quoted string of at most ' // itoa(len(field)) // &
      ' characters (this one has ' // itoa(len_trim(value)) // ')', ios, msg)
  end subroutine check_len

  !> A marker list read over unset_marker slots holds a 0 beside a marker (a 0 alone, as
  !> the header echo writes an empty list, means the list is empty).
  pure logical function zero_in_list(list)
    integer, intent(in) :: list(:)
    zero_in_list = any(list == 0) .and. any(list /= 0 .and. list /= unset_marker)
  end function zero_in_list

  !> Mark the read as failed: the caller names the item and the expected value.
  subroutine bad_value(expected, ios, msg)
    character(len=*), intent(in) :: expected
    integer, intent(out) :: ios
    character(len=*), intent(out) :: msg
    ios = -1
    msg = 'expected ' // expected
  end subroutine bad_value

  pure function expected_type(name) result(s)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    select case (trim(name))
    case ('title', 'scene', 'output', 'source', 'file', 'pattern', 'method', 'ordering', 'inner', 'particular', &
          'kind', 'f', 'u_exact', 'f_file', 'vtu_format')
      s = 'a quoted string'
    case ('breaks')
      s = 'a list of at most ' // itoa(max_breaks) // ' real numbers'
    case ('f_regions')
      s = 'a list of at most 16 quoted region names or tags'
    case ('f_region_values')
      s = 'a list of at most 16 quoted expressions'
    case ('x0', 'x1', 'y0', 'y1', 'omega', 'tol', 'rho', 'tol_h2', 'max_memory_gb', 'theta', 'max_seconds', &
          'min_growth', 'algebraic_share')
      s = 'a real number'
    case ('omega_auto', 'nested', 'enabled', 'vtk', 'latex')
      s = 'a logical, .true. or .false.'
    case ('gamma_u_names', 'gamma_a_names')
      s = 'a list of at most 16 quoted names'
    case ('format')
      s = 'a quoted string'
    case ('gamma_u_markers', 'gamma_a_markers')
      s = 'a list of at most 16 integers > 0; 0 alone is the empty list'
    case default
      s = 'an integer'
    end select
  end function expected_type

  !> The target of the assignment a: what stands before its '=' (name and subscript),
  !> without blanks, in lower case ('Levels =' and 'levels=' are the same target).
  pure function assignment_target(a) result(target)
    character(len=*), intent(in) :: a
    character(len=:), allocatable :: target
    integer :: k, eq
    eq = index(a, '=')
    target = ''
    do k = 1, eq - 1
      if (a(k:k) /= ' ') target = target // a(k:k)
    end do
    target = lower(target)
  end function assignment_target

  pure function assignment_name(a) result(name)
    character(len=*), intent(in) :: a
    character(len=64) :: name
    integer :: j, k
    k = verify(a, ' ')
    j = k
    do while (j <= len(a))
      if (.not. is_ident_char(a(j:j))) exit
      j = j + 1
    end do
    name = lower(a(k:j - 1))
  end function assignment_name

  pure logical function is_ident_start(ch)
    character(len=1), intent(in) :: ch
    is_ident_start = (ch >= 'a' .and. ch <= 'z') .or. (ch >= 'A' .and. ch <= 'Z')
  end function is_ident_start

  pure logical function is_ident_char(ch)
    character(len=1), intent(in) :: ch
    is_ident_char = is_ident_start(ch) .or. (ch >= '0' .and. ch <= '9') .or. ch == '_'
  end function is_ident_char

  !> True when a token starts at position k of s (start of line or after a separator).
  pure logical function starts_token(s, k)
    character(len=*), intent(in) :: s
    integer, intent(in) :: k
    starts_token = .true.
    if (k > 1) starts_token = is_separator(s, k - 1)
  end function starts_token

  !> True when position k of s separates tokens (blank, comma, semicolon).
  pure logical function is_separator(s, k)
    character(len=*), intent(in) :: s
    integer, intent(in) :: k
    is_separator = s(k:k) == ' ' .or. s(k:k) == ',' .or. s(k:k) == ';' .or. s(k:k) == achar(9)
  end function is_separator

  pure integer function skip_blanks(s, k) result(j)
    character(len=*), intent(in) :: s
    integer, intent(in) :: k
    j = k
    do while (j <= len_trim(s))
      if (s(j:j) /= ' ') exit
      j = j + 1
    end do
  end function skip_blanks

  !> '; did you mean <prefix>X?' for the word X of the blank-separated list `names` closest
  !> to `name` (restricted Damerau-Levenshtein distance: insertions, deletions,
  !> substitutions, swaps of neighbours) when it is at most max_typo_distance and shorter
  !> than `name`; otherwise ''.
  pure function did_you_mean(name, names, prefix) result(hint)
    character(len=*), intent(in) :: name, names, prefix
    character(len=:), allocatable :: hint
    integer, parameter :: max_typo_distance = 2
    character(len=:), allocatable :: a, b
    integer :: p, q, best, dist
    integer, allocatable :: d(:,:)
    integer :: i, j
    hint = ''
    a = trim(name)
    best = max_typo_distance + 1
    p = 1
    do while (p <= len_trim(names))
      if (names(p:p) == ' ') then
        p = p + 1
        cycle
      end if
      q = index(names(p:) // ' ', ' ') + p - 2
      b = names(p:q)
      allocate (d(0:len(a), 0:len(b)))              ! small: two names (<= 64 characters)
      d(:, 0) = [(i, i=0, len(a))]
      d(0, :) = [(j, j=0, len(b))]
      do i = 1, len(a)
        do j = 1, len(b)
          d(i, j) = min(d(i - 1, j) + 1, d(i, j - 1) + 1, d(i - 1, j - 1) + merge(0, 1, a(i:i) == b(j:j)))
          if (i > 1 .and. j > 1) then
            if (a(i:i) == b(j - 1:j - 1) .and. a(i - 1:i - 1) == b(j:j)) d(i, j) = min(d(i, j), d(i - 2, j - 2) + 1)
          end if
        end do
      end do
      dist = d(len(a), len(b))
      deallocate (d)
      if (dist < best .and. dist < len(a)) then
        best = dist
        hint = '; did you mean ' // prefix // b // '?'
      end if
      p = q + 1
    end do
  end function did_you_mean

  pure function ltoa(l) result(s)
    logical, intent(in) :: l
    character(len=:), allocatable :: s
    s = merge('.true. ', '.false.', l)
    s = trim(s)
  end function ltoa

  pure function ilist(v) result(s)
    integer, intent(in) :: v(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(v)
      if (v(k) /= 0) s = s // ' ' // itoa(v(k))
    end do
    if (len(s) == 0) s = ' 0'
    s = s(2:)
  end function ilist

  !> The non-blank names of a list, quoted and separated by commas ('' when there is none).
  pure function slist(v) result(s)
    character(len=*), intent(in) :: v(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(v)
      if (len_trim(v(k)) == 0) cycle
      if (len(s) > 0) s = s // ', '
      s = s // '''' // trim(v(k)) // ''''
    end do
    if (len(s) == 0) s = ''''''
  end function slist
end module dualsig_io_config
