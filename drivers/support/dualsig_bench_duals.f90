!> The duals section of dualsig_bench (`bin/dualsig_bench duals [lmax [scene]]`, part of
!> `make bench`): what the guaranteed bounds cost against the primal solve of the same mesh.
!>
!> One pass of the analysis pipeline with the defaults a user gets (primal method 'auto',
!> i.e. multigrid on the hierarchy from 1e4 unknowns; the default dual: P1 RT1 'nested', P2
!> equilibrium 'multigrid' (the stream function; 'augmented' on level 1); every bound
!> computed), grid
!> sequencing on the unit square from 2 x 2 cells to lmax.  Per level:
!>  - the primal solve's seconds and method;
!>  - the dual solve's seconds (the field only) and the whole dual part's (load data, dual
!>    solve, bounds: `estimate_seconds`), and their ratios to the primal solve;
!>  - the dual unknowns (P1 RT1: 2 per edge + 2 per triangle; P2 BDM1: 2 per edge) and the
!>    peak resident memory of the process (VmHWM) after the level, per dual unknown (an upper
!>    bound of the dual's own memory: the process holds the primal level as well);
!>  - the effectivity sqrt(est)/err of the bound.
!> dual_method (optional): another dual method than the default (P2: 'augmented', one
!> CHOLMOD factorisation; the table then goes to out/bench_duals_<scene>_<method>.csv).  The peak memory
!> is the process's: for a method's own figure run it alone
!> (`bin/dualsig_bench duals 10 p2_contact augmented`).
!> Table to standard output and out/bench_duals_<scene>.csv.
module dualsig_bench_duals
  use dualsig_kinds, only: dp
  use dualsig_clock, only: peak_memory_mb
  use dualsig_status, only: status_t, is_ok
  use dualsig_strings, only: itoa
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_problem_kinds, only: PROBLEM_P1
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_scene_problem, only: analysis_problem_set_scene
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, analysis_t, level_result_t, &
                              analysis_start, analysis_next_level, analysis_free
  implicit none
  private

  public :: bench_duals

  integer, parameter :: first_level = 4            !! levels below are not printed

contains

  !> The table of the module header for `scene_name` (p1_contact or p2_contact), levels to lmax.
  subroutine bench_duals(lmax, scene_name, dual_method)
    integer, intent(in) :: lmax
    character(len=*), intent(in) :: scene_name
    character(len=*), intent(in), optional :: dual_method
    type(scene_t) :: scene
    type(analysis_problem_t) :: pb
    type(analysis_settings_t) :: settings
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    integer :: level, csv, ndual, nedge
    real(dp) :: peak, eff
    character(len=:), allocatable :: label, suffix, tail
    call scene_lookup(scene_name, scene, st)
    if (.not. is_ok(st)) then
      write (*, '(a)') 'dualsig_bench duals: ' // trim(st%msg)
      return
    end if
    call mesh_rectangle(pb%mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    call analysis_problem_set_scene(pb, scene)
    settings%levels = lmax
    label = trim(merge('RT1 nested                        ', 'default: multigrid from level 2 on', &
                       scene%problem == PROBLEM_P1))
    suffix = ''
    tail = ''
    if (present(dual_method)) then
      settings%dual_method = dual_method
      label = dual_method
      suffix = '_' // dual_method
      tail = ' ' // dual_method
    end if
    open (newunit=csv, file='out/bench_duals_' // scene_name // suffix // '.csv', status='replace')
    write (csv, '(a)') 'scene,level,n_primal,primal_method,primal_s,n_dual,dual_s,estimate_s,' // &
      'dual_over_primal,estimate_over_primal,peak_mb,peak_bytes_per_dual_unknown,eff'
    write (*, '(/,a)') 'dualsig_bench: the duals against the primal solve of the same mesh, ' // scene_name // &
      ' (primal auto, dual ' // label // '; command: bin/dualsig_bench duals ' // itoa(lmax) // ' ' // scene_name // &
      tail // ')'
    write (*, '(a)') '  lvl   n_primal     method  primal_s     n_dual    dual_s  estimate_s  dual/primal' // &
      '  estimate/primal   peak MB  B/dual unknown         eff'
    call analysis_start(an, pb, settings, st)
    do level = 1, lmax
      if (.not. is_ok(st)) exit
      call analysis_next_level(an, res, st)
      if (.not. is_ok(st)) then
        write (*, '(a,i0,a)') 'dualsig_bench duals: level ', level, ': ' // trim(st%msg)
        exit
      end if
      if (level < first_level) cycle
      ! Euler's formula on the simply connected square: edges = nodes + triangles - 1
      nedge = res%nnode + res%ntri - 1
      ndual = 2 * nedge
      if (scene%problem == PROBLEM_P1) ndual = ndual + 2 * res%ntri
      peak = peak_memory_mb()
      eff = 0.0_dp
      if (res%err_energy > 0.0_dp) eff = sqrt(res%est) / res%err_energy
      write (*, '(i5, i11, a11, f10.3, i11, f10.3, f12.3, f13.1, f17.1, f10.0, f16.0, f12.6)') level, res%ndof, &
        trim(res%primal_method), res%primal_seconds, ndual, res%dual_seconds, res%estimate_seconds, &
        ratio(res%dual_seconds, res%primal_seconds), ratio(res%estimate_seconds, res%primal_seconds), &
        peak, peak * 1048576.0_dp / ndual, eff
      write (csv, '(a,",",i0,",",i0,",",a,",",es12.5,",",i0,2(",",es12.5),2(",",f0.2),",",f0.1,",",f0.1,",",f0.6)') &
        scene_name, level, res%ndof, trim(res%primal_method), res%primal_seconds, ndual, res%dual_seconds, &
        res%estimate_seconds, ratio(res%dual_seconds, res%primal_seconds), &
        ratio(res%estimate_seconds, res%primal_seconds), peak, peak * 1048576.0_dp / ndual, eff
    end do
    call analysis_free(an)
    close (csv)
    write (*, '(a)') 'dualsig_bench: table written to out/bench_duals_' // scene_name // suffix // '.csv'
  end subroutine bench_duals

  !> a / b, 0 when b is not positive (a timer's resolution).
  pure real(dp) function ratio(a, b)
    real(dp), intent(in) :: a, b
    ratio = 0.0_dp
    if (b > 0.0_dp) ratio = a / b
  end function ratio

end module dualsig_bench_duals
