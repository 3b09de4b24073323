C     EXAMPLE_DSSIGN: THE FORTRAN 77 INTERFACE OF DUALSIG.
C
C     BUILDS THE UNIT SQUARE WITH N X N CELLS, EACH CUT INTO TWO
C     TRIANGLES BY ITS DIAGONAL FROM (X0,Y0) TO (X1,Y1), SOLVES PROBLEM
C     P2 (-LAPLACE U = F, U = 0 ON THE RIGHT, TOP AND LEFT SIDES = GAMMA_U,
C     SIGNORINI CONDITIONS ON THE BOTTOM SIDE = GAMMA_A) WITH ITS OWN
C     SOURCE FUNCTION FSRC, AND PRINTS THE GUARANTEED BOUNDS.  THEN IT
C     SOLVES A 3 X 3 BOUND-CONSTRAINED QP WITH DSBQP BY BOTH METHODS.
C
C     BUILD AGAINST AN INSTALLED DUALSIG (NO MODULE FILES NEEDED):
C       gfortran example_dssign.f -L$PREFIX/lib -ldualsig
C     &        $(pkg-config --libs --static dualsig)
C
C     OUTPUT: ONE "KEY VALUE(S)" PAIR PER LINE.
      PROGRAM EXDSSG
      IMPLICIT NONE
      INTEGER N, NN, NT, NB
      PARAMETER (N = 8, NN = (N+1)**2, NT = 2*N*N, NB = 4*N)
      DOUBLE PRECISION XY(2,NN), U(NN), Q(6,NT), BOUNDS(4), ROPT(10)
      INTEGER ITRI(3,NT), IBEDGE(2,NB), IBMARK(NB), IOPT(10)
      INTEGER I, J, K, NODE, INFO, IT, NTRI, NBEDGE
      DOUBLE PRECISION UMIN, UMAX
      DOUBLE PRECISION FSRC
      EXTERNAL FSRC
C     THE QP OF DSBQP (SEE BELOW)
      INTEGER IA(4), JA(7), KIND(3), ITER, METHOD
      DOUBLE PRECISION A(7), F(3), BND(3), X(3), RES
      DATA IA /1, 3, 6, 8/
      DATA JA /1, 2,   1, 2, 3,   2, 3/
      DATA A /2D0, -1D0,   -1D0, 2D0, -1D0,   -1D0, 2D0/
      DATA F /1D0, -4D0, 1D0/
      DATA KIND /0, 1, 2/
      DATA BND /0D0, 0D0, 1D0/
C
C     NODES: NODE(I,J) = J*(N+1) + I + 1 AT (I/N, J/N), I, J = 0..N
      DO 20 J = 0, N
         DO 10 I = 0, N
            NODE = J*(N+1) + I + 1
            XY(1,NODE) = DBLE(I) / DBLE(N)
            XY(2,NODE) = DBLE(J) / DBLE(N)
   10    CONTINUE
   20 CONTINUE
C     TRIANGLES, COUNTER-CLOCKWISE: (00,10,11) AND (00,11,01) PER CELL
      NTRI = 0
      DO 40 J = 0, N-1
         DO 30 I = 0, N-1
            NODE = J*(N+1) + I + 1
            NTRI = NTRI + 1
            ITRI(1,NTRI) = NODE
            ITRI(2,NTRI) = NODE + 1
            ITRI(3,NTRI) = NODE + N + 2
            NTRI = NTRI + 1
            ITRI(1,NTRI) = NODE
            ITRI(2,NTRI) = NODE + N + 2
            ITRI(3,NTRI) = NODE + N + 1
   30    CONTINUE
   40 CONTINUE
C     BOUNDARY SIDES: BOTTOM = GAMMA_A (2); RIGHT, TOP, LEFT = GAMMA_U (1)
      NBEDGE = 0
      DO 50 K = 0, N-1
         NBEDGE = NBEDGE + 1
         IBEDGE(1,NBEDGE) = K + 1
         IBEDGE(2,NBEDGE) = K + 2
         IBMARK(NBEDGE) = 2
         NBEDGE = NBEDGE + 1
         IBEDGE(1,NBEDGE) = K*(N+1) + N + 1
         IBEDGE(2,NBEDGE) = (K+1)*(N+1) + N + 1
         IBMARK(NBEDGE) = 1
         NBEDGE = NBEDGE + 1
         IBEDGE(1,NBEDGE) = N*(N+1) + K + 1
         IBEDGE(2,NBEDGE) = N*(N+1) + K + 2
         IBMARK(NBEDGE) = 1
         NBEDGE = NBEDGE + 1
         IBEDGE(1,NBEDGE) = K*(N+1) + 1
         IBEDGE(2,NBEDGE) = (K+1)*(N+1) + 1
         IBMARK(NBEDGE) = 1
   50 CONTINUE
C     ALL OPTIONS DEFAULT (ACTIVE-SET PRIMAL, AUGMENTED-LAGRANGIAN DUAL)
      DO 60 K = 1, 10
         IOPT(K) = 0
         ROPT(K) = 0D0
   60 CONTINUE
C
      CALL DSSIGN(2, NN, XY, NTRI, ITRI, NBEDGE, IBEDGE, IBMARK, FSRC,
     &            IOPT, ROPT, U, Q, BOUNDS, INFO)
C
      UMIN = U(1)
      UMAX = U(1)
      DO 70 K = 2, NN
         UMIN = MIN(UMIN, U(K))
         UMAX = MAX(UMAX, U(K))
   70 CONTINUE
      WRITE (*, '(A, I8)') 'DSSIGN_NNODE ', NN
      WRITE (*, '(A, I8)') 'DSSIGN_NTRI ', NTRI
      WRITE (*, '(A, I8)') 'DSSIGN_INFO ', INFO
      WRITE (*, '(A, 1P, E24.16)') 'DSSIGN_EST ', BOUNDS(1)
      WRITE (*, '(A, 1P, E24.16)') 'DSSIGN_ENERGY_LO ', BOUNDS(2)
      WRITE (*, '(A, 1P, E24.16)') 'DSSIGN_ENERGY_HI ', BOUNDS(3)
      WRITE (*, '(A, 1P, E24.16)') 'DSSIGN_OSCILLATION ', BOUNDS(4)
      WRITE (*, '(A, 1P, 2E24.16)') 'DSSIGN_U_MIN_MAX ', UMIN, UMAX
C     THE BOTTOM NODES 1..N+1: U >= 0 THERE (SIGNORINI)
      WRITE (*, '(A, 1P, 9E24.16)') 'DSSIGN_U_BOTTOM ', (U(K), K=1,N+1)
C
C     DSBQP: MIN 1/2 X'AX - F'X, A = TRIDIAG(-1, 2, -1) (3 X 3),
C     F = (1, -4, 1), X(1) FREE, X(2) >= 0, X(3) = 1.  THE SOLUTION IS
C     X = (1/2, 0, 1): WITHOUT THE BOUND X(2) WOULD BE -5/3.
      DO 90 METHOD = 1, 2
         X(1) = 0D0
         X(2) = 0D0
         X(3) = 0D0
         CALL DSBQP(3, IA, JA, A, F, KIND, BND, X, METHOD, 1D0,
     &              1D-12, 10000, ITER, RES, INFO)
         WRITE (*, '(A, I2, I8)') 'DSBQP_INFO ', METHOD, INFO
         WRITE (*, '(A, I2, 1P, 3E24.16)') 'DSBQP_X ', METHOD,
     &        (X(K), K=1,3)
         WRITE (*, '(A, I2, 1P, E24.16)') 'DSBQP_RES ', METHOD, RES
         IT = ITER
         WRITE (*, '(A, I2, I8)') 'DSBQP_ITER ', METHOD, IT
   90 CONTINUE
      END
C
C     THE SOURCE TERM F(X, Y): POSITIVE ON THE LEFT HALF (THE SOLUTION
C     LIFTS OFF THE BOTTOM SIDE), NEGATIVE ON THE RIGHT HALF (CONTACT).
      DOUBLE PRECISION FUNCTION FSRC(X, Y)
      IMPLICIT NONE
      DOUBLE PRECISION X, Y, PI
      PARAMETER (PI = 3.141592653589793D0)
      FSRC = 10D0 * SIN(2D0 * PI * X) + Y
      END
