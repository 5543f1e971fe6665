/* Analysis layer: SLEPc spectra of the generalized problem K(x) v = lambda M v over the free
   vertices (K = minus the force Jacobian, no PSD projection; M the lumped mass). */
#pragma once
#include <msim/system.h>
#include <vector>

/* omega_max = sqrt(lambda_max(K, M)) at X. Collective. */
PetscErrorCode MSimSpectrumOmegaMax(MSimSystem sys, Vec X, PetscReal *omega_max);
/* The nev largest eigenvalues lambda (descending). -eps_* and -st_* options apply. */
PetscErrorCode MSimSpectrumLargest(MSimSystem sys, Vec X, PetscInt nev, std::vector<PetscReal> &lambda);
/* -msim_spectrum: print omega_max, each explicit method's critical step, the lowest modes
   (-msim_spectrum_lowest k) and write them (-msim_spectrum_modes DIR). Returns whether it ran. */
PetscErrorCode MSimSpectrumFromOptions(MSimSystem sys, Vec X, PetscBool *ran);
