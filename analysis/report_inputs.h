#pragma once
// What the pipeline gathers for the clinical report beyond its own numbers: the scan's details
// from the PET's BIDS sidecar, the clusters worth reporting, and ages and numbers written for
// people.
#include <string>

#include "analysis/normative.h"

namespace authalic::analysis {

// Scan details from the BIDS PET sidecar (`x_pet.json` beside `x_pet.nii[.gz]`, BIDS 1.9 PET):
// TracerName, InjectedRadioactivity + InjectedRadioactivityUnits, and a date from
// AcquisitionDateTime / ScanDate / SeriesDate when present. Fields left empty when absent; no
// sidecar is not an error, a sidecar that is not JSON is an InputError naming it.
struct ScanDetails {
  std::string tracer, dose, scan_date, sidecar;  // sidecar: its path when read
};
ScanDetails scan_details_from_sidecar(const std::string& pet_path);

// Drops clusters with fewer than min_elements elements from the comparison (their elements are
// no longer marked as clustered) and numbers the others 1.. in their order; returns how many
// were dropped.
int drop_small_clusters(Comparison& comparison, int min_elements);

// "61.8" for 61.8, "67" for 67.0: one decimal at most, for ages and doses.
std::string human_number(double value);

}  // namespace authalic::analysis
