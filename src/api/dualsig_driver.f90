!> Batch driver: runs every run of a namelist file through a sequence of meshes and
!> writes one error table per run (aligned text `<output>.txt` and CSV `<output>.csv`).
!>
!> A run computes only what its scene needs: the mass matrix only for P1, error
!> integrals only when the scene has an exact solution.  Output files are written under
!> temporary names and renamed when the run is complete, so a failed run leaves no
!> partial file and keeps earlier results.
module dualsig_driver
  use, intrinsic :: iso_fortran_env, only: output_unit
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds
  use dualsig_status, only: status_t, set_error, set_warning, is_ok, DS_ERR_INPUT, DS_OK, &
                            DS_WARN_NOT_CONVERGED, DS_ERR_IO
  use dualsig_mesh, only: mesh_t, mesh_h, mesh_diameter
  use dualsig_mesh_generate, only: mesh_rectangle, mesh_lshape, mesh_holed_square
  use dualsig_mesh_refine, only: mesh_refine_uniform, mesh_prolongate_p1
  use dualsig_mesh_io, only: mesh_read_text, mesh_note_len
  use dualsig_mesh_gmsh, only: gmsh_physical_t, mesh_read_gmsh, gmsh_markers_from_names
  use dualsig_mesh_triangle, only: mesh_read_triangle, triangle_base_name
  use dualsig_mesh_quality, only: mesh_quality_t, mesh_quality, mesh_quality_report
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_qp_types, only: BOUND_FIXED
  use dualsig_spectral, only: jacobi_scaled_extremes, sor_omega_from_jacobi
  use dualsig_problem_primal, only: primal_system_t, primal_constraints, primal_assemble
  use dualsig_problem_kinds, only: PROBLEM_P1
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_estimate_errors, only: p1_error_norms, exact_energy
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_solve
  use dualsig_estimate_dual_p1, only: dual_p1_bounds_t, dual_p1_bounds, dual_p1_errors
  use dualsig_problem_dual_p2, only: dual_p2_settings_t, dual_p2_result_t, dual_p2_field_t, dual_p2_solve
  use dualsig_problem_dual_p2, only: dual_p2_lambda
  use dualsig_estimate_dual_p2, only: dual_p2_bounds_t, dual_p2_bounds, dual_p2_error
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_sparse_direct, only: ORDERING_BEST, ORDERING_AMD, ORDERING_METIS, ORDERING_NATURAL, ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: geometric_ordering
  use dualsig_io_config, only: run_config_t, read_config_file, config_echo
  use dualsig_io_table, only: table_t, table_init, table_new_row, table_set, table_value, &
                              table_write_text, table_write_csv, table_format_row, &
                              table_format_header, observed_rate
  use dualsig_io_table, only: table_write_latex
  use dualsig_io_vtk, only: vtk_fields_t, vtk_write_level, vtk_write_collection, vtk_commit_run, &
                            vtk_discard_run, vtk_level_path, vtk_contact_status
  use dualsig_strings, only: itoa, rtoa
  use dualsig_io_files, only: file_commit, file_delete, temp_name, ensure_parent_dir
  implicit none
  private

  public :: run_namelist_file, run_one, primal_columns, dual_columns

  !> Degree of the quadrature for load vectors (>= 5 as required; Radon's rule).
  integer, parameter :: load_degree = 5
  !> Degree of the quadrature for integrals of the exact solution.
  integer, parameter :: exact_degree = 16
  !> Degree of the quadrature of the P2 bounds (lambda^h is not a polynomial; each point
  !> costs a line integral of f).
  integer, parameter :: bound_degree_p2 = 12
  !> Largest relative divergence defect of the P2 dual field for which est is reported as a
  !> guaranteed bound without warning.
  real(dp), parameter :: admissible_defect = 1.0e-10_dp
  !> Lanczos settings for the automatic SOR parameter.
  integer, parameter :: lanczos_max_steps = 400
  real(dp), parameter :: lanczos_rel_tol = 1.0e-3_dp
  !> The exact solutions of the catalogue live on the unit square; bounding-box tolerance.
  real(dp), parameter :: domain_tol = 1.0e-12_dp
  !> ParaView output: a Signorini node is shown in contact when u_h - obstacle <= this
  !> times max|u_h| (the solvers put contact nodes on the obstacle; this absorbs rounding).
  real(dp), parameter :: contact_rel_tol = 1.0e-12_dp

  !> Columns of the error table ('#' marks integer columns).
  character(len=16), parameter :: primal_columns(10) = [character(len=16) :: &
    '#level', 'h', '#ndof', '#primal_iters', 'primal_s', 'err_u_H1', 'rate_u_H1', &
    'err_u_L2', 'rate_u_L2', 'kkt_residual']
  !> Columns appended when the dual analysis runs.
  character(len=16), parameter :: dual_columns(12) = [character(len=16) :: &
    '#dual_iters', 'dual_s', 'err_q_Q', 'rate_q_Q', 'est', 'eff', 'energy_lo', 'energy_hi', &
    'err_q_L2', 'rate_q_L2', 'err_lambda3', 'rate_lambda3']

contains

  !> Run every run of the namelist file `path`, printing progress on `unit`
  !> (default: standard output).  Stops at the first run that fails; st carries a
  !> warning (DS_WARN_NOT_CONVERGED) when a solve hit its iteration limit.
  subroutine run_namelist_file(path, st, unit)
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    integer, intent(in), optional :: unit
    type(run_config_t), allocatable :: runs(:)
    type(status_t) :: st_run
    integer :: r, out
    out = output_unit
    if (present(unit)) out = unit
    call read_config_file(path, runs, st)
    if (st%code /= 0) return
    ! every run's output must be writable before anything is computed
    do r = 1, size(runs)
      call check_output_writable(runs(r), st)
      if (st%code /= 0) return
    end do
    do r = 1, size(runs)
      call run_one(runs(r), st_run, out)
      if (.not. is_ok(st_run)) then
        st = st_run
        return
      end if
      if (st_run%code /= DS_OK) call set_warning(st, st_run%code, st_run%msg)
    end do
  end subroutine run_namelist_file

  !> One run (run_levels); a failed run leaves none of its files, not even the temporary
  !> .vtu files written level by level.
  subroutine run_one(cfg, st, unit, table)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    type(table_t), intent(out), optional :: table
    call run_levels(cfg, st, unit, table)
    if (.not. is_ok(st) .and. cfg%vtk) call vtk_discard_run(cfg%output, cfg%levels)
  end subroutine run_one

  !> One run: build the coarse mesh, then for each level refine, assemble, solve, measure
  !> the errors and append a row; finally write `<output>.txt` and `<output>.csv` (and, on
  !> request, `<output>.tex`, one `<output>_levelLL.vtu` per level and `<output>.pvd`).
  subroutine run_levels(cfg, st, unit, table)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    type(table_t), intent(out), optional :: table
    type(run_config_t) :: resolved
    logical :: stop_run
    type(scene_t) :: scene
    type(mesh_t) :: mesh, finer
    type(primal_system_t) :: sys
    type(psor_settings_t) :: settings
    type(psor_result_t) :: res
    type(tri_rule_t) :: load_rule, exact_rule, bound_rule, bound_rule_p2
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    type(dual_p1_settings_t) :: dset
    type(dual_p2_settings_t) :: d2set
    character(len=:), allocatable :: dual_method
    type(table_t) :: tab
    type(mesh_quality_t) :: q0
    type(status_t) :: st_solve
    integer, allocatable :: gamma_u(:), gamma_a(:)
    real(dp), allocatable :: u(:), u_prev(:)
    real(dp) :: h, err_l2, err_h1semi, err_energy, rate, seconds, lmin, lmax
    integer :: level, steps, nflip, nonconverged
    logical :: ok
    character(len=300), allocatable :: header(:)
    character(len=:), allocatable :: txt_path, csv_path, norm_name, matrices, parts, title
    character(len=300) :: line
    type(vtk_fields_t) :: vfields
    character(len=:), allocatable :: tex_path
    type(gmsh_physical_t) :: phys                     ! physical names of a Gmsh mesh
    character(len=mesh_note_len), allocatable :: mesh_notes(:)
    character(len=:), allocatable :: mesh_format, tri_base
    logical :: is_triangle, by_names
    integer :: inote

    title = trim(cfg%title)
    if (len(title) == 0) title = trim(cfg%output)
    call check_output_writable(cfg, st)
    if (st%code /= 0) return
    call scene_lookup(cfg%scene, scene, st)
    if (st%code /= 0) then
      st%msg = cfg%source_file // ': &run scene: ' // st%msg
      return
    end if
    if (any(cfg%gamma_u_markers /= 0) .or. any(cfg%gamma_a_markers /= 0)) then
      gamma_u = cfg%gamma_u_markers
      gamma_a = cfg%gamma_a_markers
    else
      gamma_u = scene%gamma_u_markers
      gamma_a = scene%gamma_a_markers
    end if

    ! ---- coarse mesh
    nflip = 0
    select case (trim(cfg%mesh_source))
    case ('rectangle')
      call mesh_rectangle(mesh, cfg%x0, cfg%x1, cfg%y0, cfg%y1, cfg%nx, cfg%ny, cfg%pattern, st)
    case ('lshape')
      call mesh_lshape(mesh, cfg%n, st)
    case ('holed_square')
      call mesh_holed_square(mesh, cfg%n, st)
    case ('file')
      ! format 'auto': a name ending in .msh is Gmsh; a Triangle file (.node, .ele, .poly, .edge)
      ! or a base name with .node and .ele files is Triangle; anything else the dualsig format
      mesh_format = trim(cfg%mesh_format)
      if (mesh_format == 'auto') then
        call triangle_base_name(trim(cfg%mesh_file), tri_base, is_triangle)
        mesh_format = trim(merge('triangle', 'dualsig ', is_triangle))
        if (len_trim(cfg%mesh_file) > len('.msh')) then
          if (cfg%mesh_file(len_trim(cfg%mesh_file) - 3:len_trim(cfg%mesh_file)) == '.msh') mesh_format = 'gmsh'
        end if
      end if
      select case (mesh_format)
      case ('gmsh')
        call mesh_read_gmsh(trim(cfg%mesh_file), mesh, phys, st, nflip, mesh_notes)
      case ('triangle')
        call mesh_read_triangle(trim(cfg%mesh_file), mesh, st, nflip, mesh_notes)
      case default
        call mesh_read_text(trim(cfg%mesh_file), mesh, st, nflip)
      end select
      if (allocated(mesh_notes)) then
        do inote = 1, size(mesh_notes)
          write (unit, '(a)') "note: mesh file '" // trim(cfg%mesh_file) // "': " // trim(mesh_notes(inote))
        end do
      end if
    end select
    if (st%code /= 0) then
      st%msg = cfg%source_file // ': run of line ' // itoa(cfg%line) // ', &mesh: ' // st%msg
      return
    end if
    if (nflip > 0) write (unit, '(a,i0,a)') "warning: mesh file '" // trim(cfg%mesh_file) // "': ", nflip, &
      ' clockwise triangle(s) reoriented (expected counter-clockwise vertices; n2 and n3 swapped)'
    ! boundary parts by Gmsh physical-curve name: the markers are the physical tags
    by_names = any(cfg%gamma_u_names /= '') .or. any(cfg%gamma_a_names /= '')
    if (by_names) then
      call gmsh_markers_from_names(phys, cfg%gamma_u_names, '&run gamma_u_names', trim(cfg%mesh_file), gamma_u, st)
      if (st%code == 0) call gmsh_markers_from_names(phys, cfg%gamma_a_names, '&run gamma_a_names', &
                                                     trim(cfg%mesh_file), gamma_a, st)
      if (st%code /= 0) then
        st%msg = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': ' // st%msg
        return
      end if
      line = 'boundary by name: Gamma_u markers'
      do inote = 1, size(gamma_u)
        if (gamma_u(inote) /= 0) line = trim(line) // ' ' // itoa(gamma_u(inote))
      end do
      line = trim(line) // ', Gamma_a markers'
      do inote = 1, size(gamma_a)
        if (gamma_a(inote) /= 0) line = trim(line) // ' ' // itoa(gamma_a(inote))
      end do
      write (unit, '(a)') trim(line)
    end if
    if (scene%has_exact .and. scene%domain == 'unit_square') then
      if (abs(minval(mesh%xy(1, :))) > domain_tol .or. abs(maxval(mesh%xy(1, :)) - 1.0_dp) > domain_tol &
          .or. abs(minval(mesh%xy(2, :))) > domain_tol .or. abs(maxval(mesh%xy(2, :)) - 1.0_dp) > domain_tol) then
        call set_error(st, DS_ERR_INPUT, cfg%source_file // ': run of line ' // itoa(cfg%line) // &
          ': scene ' // trim(scene%name) // ' has its exact solution on the unit square (0,1)^2; ' // &
          'the mesh covers another domain')
        return
      end if
    end if
    q0 = mesh_quality(mesh)

    ! ---- table and output names
    txt_path = trim(cfg%output) // '.txt'
    csv_path = trim(cfg%output) // '.csv'
    call ensure_parent_dir(txt_path, st)
    if (st%code /= 0) return
    if (cfg%dual_enabled) then
      call table_init(tab, [primal_columns, dual_columns])
    else
      call table_init(tab, primal_columns)
    end if

    load_rule = tri_rule(load_degree)
    if (scene%has_exact) exact_rule = tri_rule(exact_degree)
    if (cfg%dual_enabled) bound_rule = tri_rule(exact_degree)
    if (cfg%dual_enabled) bound_rule_p2 = tri_rule(bound_degree_p2)
    settings%omega = cfg%omega
    settings%tol = cfg%tol
    settings%max_iter = cfg%max_iter
    settings%check_every = cfg%check_every
    aset%max_iter = cfg%max_iter
    dual_method = trim(cfg%dual_method)
    if (dual_method == 'default') dual_method = trim(merge('active_set', 'augmented ', scene%problem == PROBLEM_P1))
    if (cfg%dual_enabled) then
      if ((scene%problem == PROBLEM_P1 .and. dual_method == 'augmented') .or. &
          (scene%problem /= PROBLEM_P1 .and. dual_method == 'active_set')) then
        call set_error(st, DS_ERR_INPUT, cfg%source_file // ': run of line ' // itoa(cfg%line) // &
          ': &dual method = ''' // dual_method // ''' does not apply to problem P' // itoa(scene%problem) // &
          '; P1: active_set or uzawa, P2: augmented or uzawa')
        return
      end if
    end if
    dset%method = dual_method
    d2set%method = dual_method
    d2set%rho = cfg%dual_rho
    d2set%max_iter = cfg%dual_max_iter
    dset%rho = cfg%dual_rho
    dset%max_iter = cfg%dual_max_iter
    select case (trim(cfg%dual_ordering))
    case ('nd')
      dset%ordering = ORDERING_GEOMETRIC
    case ('amd')
      dset%ordering = ORDERING_AMD
    case ('metis')
      dset%ordering = ORDERING_METIS
    case ('natural')
      dset%ordering = ORDERING_NATURAL
    case ('best')
      dset%ordering = ORDERING_BEST
    case default
      dset%ordering = ORDERING_AMD
    end select
    aset%ordering = dset%ordering
    d2set%ordering = dset%ordering
    d2set%inner = cfg%dual_inner
    nonconverged = 0

    write (unit, '(a)') 'dualsig: run "' // trim(title) // '" (scene ' // trim(scene%name) // &
      ', ' // trim(cfg%source_file) // ' line ' // itoa(cfg%line) // ')'
    call mesh_quality_report(q0, unit)
    write (unit, '(a)') table_format_header(tab)
    do level = 1, cfg%levels
      if (level > 1) then
        call mesh_refine_uniform(mesh, finer, st)
        if (st%code /= 0) return
        if (cfg%nested) then
          allocate (u_prev(finer%nnode))
          call mesh_prolongate_p1(mesh, finer, u, u_prev)
        end if
        mesh = finer
      end if
      h = mesh_h(mesh)
      call primal_assemble(mesh, scene%problem, scene%f, load_rule, sys)
      call primal_constraints(mesh, scene%problem, gamma_u, gamma_a, sys%kind, sys%bnd, st, &
                              every_loop_gamma_u=cfg%dual_enabled .and. scene%problem /= PROBLEM_P1)
      if (st%code /= 0) then
        st%msg = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': ' // st%msg
        return
      end if
      if (allocated(u_prev)) then
        call move_alloc(u_prev, u)
      else
        if (allocated(u)) deallocate (u)
        allocate (u(mesh%nnode), source=0.0_dp)
      end if

      seconds = wall_seconds()
      if (cfg%method == 'active_set') then
        if (dset%ordering == ORDERING_GEOMETRIC) then
          ! nested dissection from the node coordinates (large meshes), AMD otherwise
          call geometric_ordering(mesh%xy, sys%a, aset%ordering, aset%perm, st)
          if (st%code /= 0) return
        end if
        call active_set_solve(sys%a, sys%load, sys%kind, sys%bnd, u, aset, ares, st_solve)
        res%iterations = ares%iterations
        res%kkt_residual = ares%kkt_residual
        res%converged = ares%converged
      else
        if (cfg%omega_auto) then
          call jacobi_scaled_extremes(sys%a, sys%kind /= BOUND_FIXED, lanczos_max_steps, lanczos_rel_tol, &
                                      lmin, lmax, steps, st)
          if (st%code /= 0) return
          settings%omega = sor_omega_from_jacobi(lmin, lmax)
        end if
        call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, settings, res, st_solve)
      end if
      seconds = wall_seconds() - seconds
      call take_status(st_solve, stop_run)
      if (stop_run) return

      call table_new_row(tab)
      call table_set(tab, 'level', real(level, dp))
      call table_set(tab, 'h', h)
      call table_set(tab, 'ndof', real(count(sys%kind /= BOUND_FIXED), dp))
      call table_set(tab, 'primal_iters', real(res%iterations, dp))
      call table_set(tab, 'primal_s', seconds)
      call table_set(tab, 'kkt_residual', res%kkt_residual)
      if (scene%has_exact) then
        call p1_error_norms(mesh, u, scene%u, scene%grad_u, exact_rule, err_l2, err_h1semi)
        ! the energy norm of the problem: full H1 norm for P1, H1 seminorm for P2
        if (scene%problem == PROBLEM_P1) then
          err_energy = sqrt(err_l2**2 + err_h1semi**2)
        else
          err_energy = err_h1semi
        end if
        call table_set(tab, 'err_u_H1', err_energy)
        call table_set(tab, 'err_u_L2', err_l2)
        if (level > 1) then
          call observed_rate(table_value(tab, level - 1, 'err_u_H1'), err_energy, &
                             table_value(tab, level - 1, 'h'), h, rate, ok)
          if (ok) call table_set(tab, 'rate_u_H1', rate)
          call observed_rate(table_value(tab, level - 1, 'err_u_L2'), err_l2, &
                             table_value(tab, level - 1, 'h'), h, rate, ok)
          if (ok) call table_set(tab, 'rate_u_L2', rate)
        end if
      end if
      if (cfg%dual_enabled) then
        if (scene%problem == PROBLEM_P1) then
          call dual_level_p1()
        else
          call dual_level_p2()
        end if
        if (.not. is_ok(st)) return
      end if
      if (cfg%vtk) call vtk_level()
      if (.not. is_ok(st)) return
      write (unit, '(a)') table_format_row(tab, level)
      flush (unit)
    end do

    ! ---- header and files
    allocate (header(0))
    if (scene%problem == PROBLEM_P1) then
      norm_name = 'the full H1 norm ||.||_1'
      matrices = 'K + M'
    else
      norm_name = 'the H1 seminorm |.|_1'
      matrices = 'K (no mass matrix)'
    end if
    if (cfg%method == 'active_set') then
      parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (primal-dual active set, CHOLMOD, ' // &
        'ordering ' // trim(cfg%dual_ordering) // ')'
    else
      parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (projected SOR'
      if (cfg%omega_auto) parts = parts // ', omega from a Lanczos estimate'
      parts = parts // ')'
    end if
    if (scene%has_exact) then
      parts = parts // ', exact errors (degree-' // itoa(exact_degree) // ' quadrature)'
    else
      parts = parts // ', no exact solution: error columns nan'
    end if
    if (cfg%dual_enabled .and. scene%problem == PROBLEM_P1) then
      parts = parts // '; dual analysis: P1 vector fields, ' // dual_method // &
        ' with a CHOLMOD factorisation; bounds (6.13), (6.14) from the feasible q'
    else if (cfg%dual_enabled) then
      parts = parts // '; dual analysis: equilibrium elements, ' // dual_method
      if (dual_method == 'augmented') parts = parts // ' (inner solver ' // trim(cfg%dual_inner) // ')'
      parts = parts // &
        '; lambda^h = lambda^f + q^h admissible; bounds (6.26), Theorem 6.4'
    else
      parts = parts // '; dual analysis not requested'
    end if
    header = [character(len=300) :: &
      'dualsig error table: ' // trim(title), &
      'scene ' // trim(scene%name) // ': ' // trim(scene%description), &
      'problem P' // itoa(scene%problem) // '; err_u_H1 is ' // norm_name // ' of u - u_h (the energy norm)', &
      parts, &
      'coarse mesh: ' // itoa(q0%nnode) // ' nodes, ' // itoa(q0%ntri) // ' triangles, ' // &
        itoa(q0%nloop) // ' boundary loop(s), min angle ' // rtoa(q0%min_angle_deg) // &
        ' deg, max side ratio in a triangle ' // rtoa(q0%max_tri_side_ratio) // &
        ' (uniform refinement keeps both)', &
      'h = longest side; ndof = unknowns not fixed by Gamma_u; primal_s = wall time of the ' // &
        'solve; rates = observed orders between levels', &
      'namelist (resolved):']
    if (cfg%dual_enabled) then
      if (scene%problem == PROBLEM_P1) then
        line = 'est = E(q_h, u_h) of (6.13) >= ||u - u_h||_1^2; eff = sqrt(est) / err_u_H1; err_q_Q = ' // &
          '(err_q_L2^2 + err_lambda3^2)^(1/2), err_q_L2 = ||q - grad u||, err_lambda3 = ||f + div q - u||; ' // &
          'energy_lo <= ||u||_1^2 = (f,u) <= energy_hi (6.14)'
      else
        line = 'est = E(lambda_h, u_h) of (6.26) >= |u - u_h|_1^2; eff = sqrt(est) / err_u_H1; err_q_Q = ' // &
          '||grad u - lambda_h||_0; energy_lo <= |u|_1^2 = (f,u) <= energy_hi (Theorem 6.4)'
      end if
      header = [character(len=300) :: header(1:size(header) - 1), line, header(size(header))]
      if (scene%has_exact) then
        line = 'exact energy (f, u) = ' // rtoa(exact_energy(mesh, scene%u, scene%grad_u, exact_rule, &
          scene%problem == PROBLEM_P1))
        header = [character(len=300) :: header(1:size(header) - 1), line, header(size(header))]
      end if
    end if
    resolved = cfg
    if (.not. by_names) then                       ! by name: the echo keeps the names
      resolved%gamma_u_markers = 0
      resolved%gamma_a_markers = 0
      resolved%gamma_u_markers(1:size(gamma_u)) = gamma_u
      resolved%gamma_a_markers(1:size(gamma_a)) = gamma_a
    end if
    header = [header, config_echo(resolved)]
    if (nonconverged > 0) then
      write (line, '(a,i0,a)') 'WARNING: ', nonconverged, ' level(s) stopped at max_iter (see kkt_residual)'
      header = [header, line]
    end if
    call table_write_text(tab, txt_path, header, st)
    if (st%code /= 0) return
    call table_write_csv(tab, csv_path, st)
    if (st%code /= 0) then
      call file_delete(temp_name(txt_path))
      return
    end if
    tex_path = trim(cfg%output) // '.tex'
    if (cfg%latex) call table_write_latex(tab, tex_path, title, st)
    if (st%code == 0 .and. cfg%vtk) call vtk_write_collection(cfg%output, cfg%levels, st)
    if (st%code /= 0) then
      call file_delete(temp_name(txt_path))
      call file_delete(temp_name(csv_path))
      call file_delete(temp_name(tex_path))
      return
    end if
    call file_commit(txt_path, st)
    if (st%code == 0) call file_commit(csv_path, st)
    if (st%code == 0 .and. cfg%latex) call file_commit(tex_path, st)
    if (st%code == 0 .and. cfg%vtk) call vtk_commit_run(cfg%output, cfg%levels, st)
    if (st%code /= 0) then
      call file_delete(temp_name(txt_path))
      call file_delete(temp_name(csv_path))
      call file_delete(temp_name(tex_path))
      return
    end if
    write (unit, '(a)') 'dualsig: table written to ' // txt_path // ' and ' // csv_path
    if (cfg%latex) write (unit, '(a)') 'dualsig: LaTeX table written to ' // tex_path
    if (cfg%vtk) write (unit, '(a)') 'dualsig: ParaView files written: ' // trim(cfg%output) // &
      '.pvd and ' // itoa(cfg%levels) // ' level file(s) ' // trim(cfg%output) // '_levelLL.vtu'
    if (nonconverged > 0) call set_warning(st, DS_WARN_NOT_CONVERGED, &
      itoa(nonconverged) // ' level(s) of run "' // trim(cfg%title) // '" did not converge')
    if (present(table)) table = tab

  contains

    !> The dual analysis of P1 on the current level: feasible q, bounds, dual errors, columns.
    subroutine dual_level_p1()
      real(dp), allocatable :: q(:)
      type(dual_p1_result_t) :: dres
      type(dual_p1_bounds_t) :: bounds
      type(status_t) :: st_dual
      real(dp) :: t0, err_q, err_div, err_qnorm
      ! Uzawa tolerance tied to the discretisation: no point in solving far below h^2
      dset%tol = max(cfg%dual_tol, cfg%dual_tol_h2 * (h / mesh_diameter(mesh))**2)
      t0 = wall_seconds()
      call dual_p1_solve(mesh, scene%f, load_rule, dset, q, dres, st_dual, u_primal=u)
      t0 = wall_seconds() - t0
      call take_status(st_dual, stop_run)
      if (stop_run) return
      call dual_p1_bounds(mesh, u, q, scene%f, bound_rule, bounds, scene%x_breaks(1:scene%nbreaks))
      if (cfg%vtk) then
        vfields%q_h = reshape(q, [2, mesh%nnode])
        vfields%est_element = bounds%est_elem
        vfields%est = bounds%est
        vfields%has_est = .true.
      end if
      call table_set(tab, 'dual_iters', real(dres%iterations, dp))
      call table_set(tab, 'dual_s', t0)
      call table_set(tab, 'est', bounds%est)
      call table_set(tab, 'energy_lo', bounds%energy_lo)
      call table_set(tab, 'energy_hi', bounds%energy_hi)
      if (scene%has_exact) then
        call dual_p1_errors(mesh, q, scene%f, scene%u, scene%grad_u, exact_rule, err_q, err_div, err_qnorm, &
                            scene%x_breaks(1:scene%nbreaks))
        call set_with_rate('err_q_Q', 'rate_q_Q', err_qnorm)
        call set_with_rate('err_q_L2', 'rate_q_L2', err_q)
        call set_with_rate('err_lambda3', 'rate_lambda3', err_div)
        if (err_energy > 0.0_dp) call table_set(tab, 'eff', sqrt(bounds%est) / err_energy)
      end if
      write (unit, '(a,i0,a,i0,a,a,a,i0,a,i0,a,i0,a,es9.2,a,i0,a,i0)') '  dual level ', level, ': ', &
        dres%iterations, ' iterations (', dual_method, '), factorisations ', dres%factorisations, &
        ', bordered ', dres%lowrank_solves, ', nnz(L) = ', dres%nnz_factor, ', residual ', dres%residual, &
        ', constraints ', dres%nconstraints, ', active ', dres%nactive
      if (cfg%dual_method == 'uzawa') write (unit, '(a,es10.3,a,es10.3,a,i0)') '    rho = ', dres%rho, &
        ', lambda_max(B A^-1 B^T) ~ ', dres%lambda_max, ', retries ', dres%retries
      write (unit, '(a,a)') '    ordering ', trim(dres%ordering)
    end subroutine dual_level_p1

    !> The dual analysis of P2 on the current level: equilibrium elements, admissible
    !> lambda^h = lambda^f + q^h, bounds (6.26) and Theorem 6.4, ||grad u - lambda^h||.
    subroutine dual_level_p2()
      type(dual_p2_field_t) :: field
      type(dual_p2_result_t) :: dres
      type(dual_p2_bounds_t) :: bounds
      type(status_t) :: st_dual
      logical, allocatable :: is_gamma_a(:)
      integer :: j, i
      real(dp) :: t0
      allocate (is_gamma_a(mesh%nbedge))
      do j = 1, mesh%nbedge
        is_gamma_a(j) = any(gamma_a == mesh%bedge_marker(j))
      end do
      d2set%tol = max(cfg%dual_tol, cfg%dual_tol_h2 * (h / mesh_diameter(mesh))**2)
      t0 = wall_seconds()
      call dual_p2_solve(mesh, scene%f, is_gamma_a, minval(mesh%xy(1, :)), d2set, field, dres, st_dual, &
                         scene%x_breaks(1:scene%nbreaks), u)
      t0 = wall_seconds() - t0
      call take_status(st_dual, stop_run)
      if (stop_run) return
      if (dres%defect > admissible_defect) then
        nonconverged = nonconverged + 1
        write (unit, '(a,i0,a,es9.2,a)') 'warning: level ', level, ': the dual field has a divergence defect ', &
          dres%defect, ' (relative): lambda_h is not admissible and est is NOT a guaranteed bound' // &
          ' (even after the exact equilibration of the solver''s field)'
      end if
      call dual_p2_bounds(mesh, u, field, scene%f, is_gamma_a, bound_rule_p2, bounds)
      if (cfg%vtk) then
        ! lambda^h at the centroid and, from inside the triangle, at its three vertices
        allocate (vfields%lambda_centroid(2, mesh%ntri), vfields%lambda_vertices(6, mesh%ntri))
        do j = 1, mesh%ntri
          vfields%lambda_centroid(:, j) = dual_p2_lambda(field, mesh, scene%f, j, [1.0_dp, 1.0_dp, 1.0_dp] / 3.0_dp)
          do i = 1, 3
            vfields%lambda_vertices(2 * i - 1:2 * i, j) = dual_p2_lambda(field, mesh, scene%f, j, &
              merge(1.0_dp, 0.0_dp, [1, 2, 3] == i))
          end do
        end do
        vfields%est_element = bounds%est_elem
        vfields%est = bounds%est
        vfields%has_est = .true.
      end if
      call table_set(tab, 'dual_iters', real(dres%iterations, dp))
      call table_set(tab, 'dual_s', t0)
      call table_set(tab, 'est', bounds%est)
      call table_set(tab, 'energy_lo', bounds%energy_lo)
      call table_set(tab, 'energy_hi', bounds%energy_hi)
      if (scene%has_exact) then
        call set_with_rate('err_q_Q', 'rate_q_Q', dual_p2_error(mesh, field, scene%f, scene%grad_u, bound_rule_p2))
        if (err_energy > 0.0_dp) call table_set(tab, 'eff', sqrt(bounds%est) / err_energy)
      end if
      write (unit, '(a,i0,a,i0,a,a,a,i0,a,i0,a,es9.2,a,es9.2,a,i0,a,i0)') '  dual level ', level, ': ', dres%iterations, &
        ' iterations (', dual_method, '), factorisations ', dres%factorisations, ', nnz(L) = ', dres%nnz_factor, &
        ', divergence defect ', dres%defect, ' (solver ', dres%defect_solver, '), constraints ', dres%nconstraints, &
        ', active ', dres%nactive
      if (dual_method == 'uzawa') write (unit, '(a,es10.3,a,es10.3,a,es9.2)') '    rho = ', dres%rho, &
        ', lambda_max(B A^-1 B^T) ~ ', dres%lambda_max, ', residual ', dres%residual
      if (dual_method == 'augmented') write (unit, '(a,es10.3,a,a)') '    penalty r = ', dres%penalty, &
        ', ordering ', trim(dres%ordering)
    end subroutine dual_level_p2

    !> Write the .vtu of the current level under its temporary name (committed with the
    !> tables at the end of the run): u_h, the exact u, the contact status and the dual
    !> fields and estimator contributions collected by dual_level_p1/p2 in vfields.
    subroutine vtk_level()
      integer :: i
      if (scene%has_exact) vfields%u_exact = [(scene%u%value(mesh%xy(1, i), mesh%xy(2, i)), i=1, mesh%nnode)]
      vfields%contact = vtk_contact_status(sys%kind, sys%bnd, u, contact_rel_tol)
      call vtk_write_level(vtk_level_path(cfg%output, level), mesh, level, h, u, vfields, st)
      vfields = vtk_fields_t()
    end subroutine vtk_level

    !> Take over the status of a step of the current level: an error becomes the run's error
    !> (stop_run), a warning is counted and printed.
    subroutine take_status(st_step, stop_run)
      type(status_t), intent(in) :: st_step
      logical, intent(out) :: stop_run
      stop_run = .not. is_ok(st_step)
      if (stop_run) then
        st = st_step
        st%msg = 'level ' // itoa(level) // ': ' // st%msg
      else if (st_step%code == DS_WARN_NOT_CONVERGED) then
        nonconverged = nonconverged + 1
        write (unit, '(a)') 'warning: level ' // itoa(level) // ': ' // st_step%msg
      end if
    end subroutine take_status

    !> Set column `name` of the current row to `value` and `rate_name` to its observed order.
    subroutine set_with_rate(name, rate_name, value)
      character(len=*), intent(in) :: name, rate_name
      real(dp), intent(in) :: value
      real(dp) :: r
      logical :: ok_r
      call table_set(tab, name, value)
      if (level == 1) return
      call observed_rate(table_value(tab, level - 1, name), value, table_value(tab, level - 1, 'h'), h, r, ok_r)
      if (ok_r) call table_set(tab, rate_name, r)
    end subroutine set_with_rate
  end subroutine run_levels

  !> Fail early, before any computation, when the tables of run `cfg` cannot be written:
  !> create the output's directory (like mkdir -p), refuse an output whose table name is a
  !> directory, and create and delete the temporary file of the text table there.  Errors
  !> name the namelist file, the &run output item and the directory.
  subroutine check_output_writable(cfg, st)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: txt_path, dir, where
    character(len=256) :: iom
    integer :: u, ios, k
    logical :: is_dir
    txt_path = trim(cfg%output) // '.txt'
    k = index(txt_path, '/', back=.true.)
    if (k == 0) then
      dir = '.'
    else if (k == 1) then
      dir = '/'
    else
      dir = txt_path(1:k - 1)
    end if
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ": &run output = '" // &
      trim(cfg%output) // "': "
    call ensure_parent_dir(txt_path, st)
    if (st%code /= 0) then
      st%msg = where // st%msg // " (expected a writable directory '" // dir // "' or one that can be created)"
      return
    end if
    do k = 1, 2
      inquire (file=trim(cfg%output) // merge('.txt/.', '.csv/.', k == 1), exist=is_dir)
      if (is_dir) then
        call set_error(st, DS_ERR_IO, where // trim(cfg%output) // merge('.txt', '.csv', k == 1) // &
          ' is a directory (expected a path for the table files, without extension)')
        return
      end if
    end do
    iom = ''
    open (newunit=u, file=temp_name(txt_path), status='replace', action='write', iostat=ios, iomsg=iom)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, where // "cannot create files in the directory '" // dir // "' (" // &
        trim(iom) // '; expected a writable directory)')
      return
    end if
    close (u, status='delete', iostat=ios)
  end subroutine check_output_writable

end module dualsig_driver
