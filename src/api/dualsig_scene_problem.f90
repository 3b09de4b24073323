!> The analysis problem of a scene: a scene of dualsig_scenes (a preset load, its default
!> boundary parts, break lines and, for the manufactured scenes, the exact solution) written
!> into an analysis_problem_t of dualsig_analysis, for the programs and tests that pose a
!> scene on a mesh of their own (the bench, the stress program, the test suite).  The
!> namelist driver keeps its own version: its boundary parts come from &run.
module dualsig_scene_problem
  use dualsig_scenes, only: scene_t
  use dualsig_analysis, only: analysis_problem_t
  implicit none
  private

  public :: analysis_problem_set_scene

contains

  !> Set everything of pb but its mesh from the scene: the problem kind, Gamma_u and Gamma_a
  !> (the scene's default markers), the load, its break lines and, when the scene has one and
  !> `exact` is not .false., the exact solution and its gradient.  Fields pb held before are
  !> released first, so pb may be reused scene after scene.
  subroutine analysis_problem_set_scene(pb, scene, exact)
    type(analysis_problem_t), intent(inout) :: pb
    type(scene_t), intent(in) :: scene
    logical, intent(in), optional :: exact   !! attach the exact solution (default .true.)
    logical :: with_exact
    with_exact = scene%has_exact
    if (present(exact)) with_exact = with_exact .and. exact
    if (allocated(pb%f)) deallocate (pb%f)
    if (allocated(pb%u_exact)) deallocate (pb%u_exact)
    if (allocated(pb%grad_exact)) deallocate (pb%grad_exact)
    ! (allocate with source: gfortran 12 mis-assigns to an allocated polymorphic component)
    allocate (pb%f, source=scene%f)                      ! small: a scene's function field
    if (with_exact) then
      allocate (pb%u_exact, source=scene%u)              ! small: a scene's function field
      allocate (pb%grad_exact, source=scene%grad_u)      ! small: a scene's function field
    end if
    pb%kind = scene%problem
    pb%gamma_u = scene%gamma_u_markers
    pb%gamma_a = scene%gamma_a_markers
    pb%x_breaks = scene%x_breaks(1:scene%nbreaks)
  end subroutine analysis_problem_set_scene

end module dualsig_scene_problem
