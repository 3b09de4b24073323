!> The two problems of the paper (Hlavacek 1977), named once for every layer:
!>   P1: -Lap u + u = f in Omega, Signorini conditions u >= 0, du/dnu >= 0, u du/dnu = 0
!>       on all of Gamma (energy norm: the full H1 norm);
!>   P2: -Lap u = f in Omega, u = 0 on Gamma_u, Signorini conditions on Gamma_a (energy
!>       norm: the H1 seminorm).
!> nu is the outward unit normal; triangles are counter-clockwise.
module dualsig_problem_kinds
  implicit none
  private

  public :: PROBLEM_P1, PROBLEM_P2

  integer, parameter :: PROBLEM_P1 = 1   !! -Lap u + u = f, Signorini on all of Gamma
  integer, parameter :: PROBLEM_P2 = 2   !! -Lap u = f, u = 0 on Gamma_u, Signorini on Gamma_a
end module dualsig_problem_kinds
