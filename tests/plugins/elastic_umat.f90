! geocel's isotropic linear (hypo)elastic soil model as an Abaqus/Standard UMAT (test plug-in, Fortran).
!
! The same model and the same floating-point operations, in the same order, as the C plug-in elastic.c
! (a port of geocel.materials.elastic.elastic_update), so that both give the same numbers:
!
!     dsigma = lambda tr(deps) I + 2 mu deps,  mu = E / (2 (1 + nu)),  lambda = E nu / ((1 + nu)(1 - 2 nu)),
!     e <- (1 + e) exp(tr deps) - 1                    (void ratio, kinematic update),
!
! and nothing (stress and e unchanged) for an exactly zero strain increment, as the built-in.
!
!   PROPS  = (E [Pa], nu)   NPROPS = 2 (otherwise PNEWDT = 0: geocel reports it)
!   STATEV = (e)            NSTATV >= 1 (state variables beyond the first are left as they are)
!   STRESS order 11, 22, 33, 12, 13, 23, already co-rotated by geocel; DSTRAN engineering shear;
!   DDSDDE the isotropic elastic Jacobian (engineering shear): geocel's P-wave modulus lambda + 2 mu.
!
! Parentheses fix the order of every operation (a Fortran compiler must honour them). Build without
! flags that allow FMA contraction (e.g. gfortran -O2 -fPIC -shared, no -march=native; or add
! -ffp-contract=off) to get the C plug-in's numbers to the last bit.
!
! Build: gfortran -O2 -fPIC -shared -o libelastic_umat.so elastic_umat.f90

subroutine UMAT(STRESS, STATEV, DDSDDE, SSE, SPD, SCD, RPL, DDSDDT, DRPLDE, DRPLDT, &
                STRAN, DSTRAN, TIME, DTIME, TEMP, DTEMP, PREDEF, DPRED, CMNAME, &
                NDI, NSHR, NTENS, NSTATV, PROPS, NPROPS, COORDS, DROT, PNEWDT, &
                CELENT, DFGRD0, DFGRD1, NOEL, NPT, LAYER, KSPT, KSTEP, KINC)
  implicit none
  character*80 CMNAME
  integer NDI, NSHR, NTENS, NSTATV, NPROPS, NOEL, NPT, LAYER, KSPT, KSTEP, KINC
  double precision STRESS(NTENS), STATEV(NSTATV), DDSDDE(NTENS, NTENS), SSE, SPD, SCD, RPL, &
                   DDSDDT(NTENS), DRPLDE(NTENS), DRPLDT, STRAN(NTENS), DSTRAN(NTENS), TIME(2), DTIME, &
                   TEMP, DTEMP, PREDEF(1), DPRED(1), PROPS(NPROPS), COORDS(3), DROT(3, 3), PNEWDT, &
                   CELENT, DFGRD0(3, 3), DFGRD1(3, 3)

  double precision E, nu, lam, mu, pw, tr, d(6)
  integer i, j

  if (NPROPS /= 2 .or. NSTATV < 1 .or. NTENS /= 6) then
    PNEWDT = 0.0d0  ! wrong layout: geocel reports it
    return
  end if

  ! Lame constants (elastic.lame)
  E = PROPS(1)
  nu = PROPS(2)
  mu = E / (2.0d0 * (1.0d0 + nu))
  lam = (E * nu) / ((1.0d0 + nu) * (1.0d0 - (2.0d0 * nu)))

  ! Jacobian, engineering shear
  pw = lam + (2.0d0 * mu)
  do j = 1, 6
    do i = 1, 6
      DDSDDE(i, j) = 0.0d0
    end do
  end do
  do j = 1, 3
    do i = 1, 3
      if (i == j) then
        DDSDDE(i, j) = pw
      else
        DDSDDE(i, j) = lam
      end if
    end do
  end do
  do i = 4, 6
    DDSDDE(i, i) = mu
  end do

  ! strain increment with tensor shear
  do i = 1, 3
    d(i) = DSTRAN(i)
  end do
  do i = 4, 6
    d(i) = 0.5d0 * DSTRAN(i)
  end do

  ! zero increment: nothing to do (the built-in's ZERO_INCREMENT rule)
  if (d(1) == 0.0d0 .and. d(2) == 0.0d0 .and. d(3) == 0.0d0 .and. &
      d(4) == 0.0d0 .and. d(5) == 0.0d0 .and. d(6) == 0.0d0) return

  tr = (d(1) + d(2)) + d(3)
  do i = 1, 3
    STRESS(i) = STRESS(i) + ((lam * tr) + ((2.0d0 * mu) * d(i)))
  end do
  do i = 4, 6
    STRESS(i) = STRESS(i) + ((2.0d0 * mu) * d(i))
  end do
  STATEV(1) = ((1.0d0 + STATEV(1)) * exp((d(1) + d(2)) + d(3))) - 1.0d0
end subroutine UMAT
