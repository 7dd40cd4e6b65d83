! geocel's isotropic linear (hypo)elastic soil model as an Abaqus/Explicit VUMAT (test plug-in, Fortran).
!
! The same model and the same floating-point operations, in the same order, as the C plug-in elastic.c
! (a port of geocel.materials.elastic.elastic_update), so that both give the same numbers:
!
!     dsigma = lambda tr(deps) I + 2 mu deps,  mu = E / (2 (1 + nu)),  lambda = E nu / ((1 + nu)(1 - 2 nu)),
!     e <- (1 + e) exp(tr deps) - 1                    (void ratio, kinematic update),
!
! and nothing (stressNew = stressOld, e unchanged) for an exactly zero strain increment, as the built-in.
!
!   props   = (E [Pa], nu)  nprops = 2 (otherwise stressNew and stateNew = NaN: geocel reports it)
!   state   = (e)           nstatev >= 1 (state variables beyond the first are copied through)
!   VUMAT order 11, 22, 33, 12, 23, 31, tensor shear; stressOld already co-rotated by geocel. Every
!   component of stressNew and stateNew is written.
!
! Parentheses fix the order of every operation (a Fortran compiler must honour them). Build without
! flags that allow FMA contraction (e.g. gfortran -O2 -fPIC -shared, no -march=native; or add
! -ffp-contract=off) to get the C plug-in's numbers to the last bit.
!
! Build: gfortran -O2 -fPIC -shared -o libelastic_vumat.so elastic_vumat.f90

subroutine VUMAT(nblock, ndir, nshr, nstatev, nfieldv, nprops, lanneal, &
                 stepTime, totalTime, dt, cmname, coordMp, charLength, &
                 props, density, strainInc, relSpinInc, &
                 tempOld, stretchOld, defgradOld, fieldOld, &
                 stressOld, stateOld, enerInternOld, enerInelasOld, &
                 tempNew, stretchNew, defgradNew, fieldNew, &
                 stressNew, stateNew, enerInternNew, enerInelasNew)
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none
  character*80 cmname
  integer nblock, ndir, nshr, nstatev, nfieldv, nprops, lanneal
  double precision stepTime, totalTime, dt
  double precision coordMp(nblock, *), charLength(nblock), props(nprops), density(nblock), &
                   strainInc(nblock, ndir + nshr), relSpinInc(nblock, nshr), tempOld(nblock), &
                   stretchOld(nblock, ndir + nshr), defgradOld(nblock, ndir + nshr + nshr), &
                   fieldOld(nblock, nfieldv), stressOld(nblock, ndir + nshr), stateOld(nblock, nstatev), &
                   enerInternOld(nblock), enerInelasOld(nblock), tempNew(nblock), &
                   stretchNew(nblock, ndir + nshr), defgradNew(nblock, ndir + nshr + nshr), &
                   fieldNew(nblock, nfieldv), stressNew(nblock, ndir + nshr), stateNew(nblock, nstatev), &
                   enerInternNew(nblock), enerInelasNew(nblock)

  ! geocel's order 11, 22, 33, 12, 13, 23 -> the VUMAT's column (11, 22, 33, 12, 23, 31)
  integer, parameter :: from_vumat(6) = (/ 1, 2, 3, 4, 6, 5 /)
  double precision E, nu, lam, mu, tr, nan, s(6), d(6)
  integer b, k

  if (nprops /= 2 .or. nstatev < 1 .or. ndir /= 3 .or. nshr /= 3) then
    nan = ieee_value(0.0d0, ieee_quiet_nan)  ! wrong layout: geocel reports it
    do b = 1, nblock
      do k = 1, ndir + nshr
        stressNew(b, k) = nan
      end do
      do k = 1, nstatev
        stateNew(b, k) = nan
      end do
    end do
    return
  end if

  ! Lame constants (elastic.lame)
  E = props(1)
  nu = props(2)
  mu = E / (2.0d0 * (1.0d0 + nu))
  lam = (E * nu) / ((1.0d0 + nu) * (1.0d0 - (2.0d0 * nu)))

  do b = 1, nblock
    do k = 1, 6
      s(k) = stressOld(b, from_vumat(k))
      d(k) = strainInc(b, from_vumat(k))  ! tensor shear already
    end do
    stateNew(b, 1) = stateOld(b, 1)
    ! zero increment: nothing to do (the built-in's ZERO_INCREMENT rule)
    if (.not. (d(1) == 0.0d0 .and. d(2) == 0.0d0 .and. d(3) == 0.0d0 .and. &
               d(4) == 0.0d0 .and. d(5) == 0.0d0 .and. d(6) == 0.0d0)) then
      tr = (d(1) + d(2)) + d(3)
      do k = 1, 3
        s(k) = s(k) + ((lam * tr) + ((2.0d0 * mu) * d(k)))
      end do
      do k = 4, 6
        s(k) = s(k) + ((2.0d0 * mu) * d(k))
      end do
      stateNew(b, 1) = ((1.0d0 + stateOld(b, 1)) * exp((d(1) + d(2)) + d(3))) - 1.0d0
    end if
    do k = 1, 6
      stressNew(b, from_vumat(k)) = s(k)
    end do
    do k = 2, nstatev
      stateNew(b, k) = stateOld(b, k)
    end do
  end do
end subroutine VUMAT
