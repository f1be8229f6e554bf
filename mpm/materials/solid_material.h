// One solid's constitutive model chosen at run time (scene key solids[].model), so that a
// scene can mix models while the Newton step keeps a single material type. The dispatch
// is one switch per call: negligible next to the SVD inside each model.
#pragma once

#include <string>

#include "materials/fixed_corotated.h"
#include "materials/neo_hookean.h"

namespace iqmpm {

enum class SolidModel { fixed_corotated, neo_hookean };

template <int dim>
struct SolidMaterial {
  SolidModel model = SolidModel::fixed_corotated;
  Real mu = 0;
  Real lambda = 0;

  Real energy_density(const Mat<dim>& F) const {
    return model == SolidModel::neo_hookean ? NeoHookean<dim>{mu, lambda}.energy_density(F)
                                            : FixedCorotated<dim>{mu, lambda}.energy_density(F);
  }
  Mat<dim> first_piola(const Mat<dim>& F) const {
    return model == SolidModel::neo_hookean ? NeoHookean<dim>{mu, lambda}.first_piola(F)
                                            : FixedCorotated<dim>{mu, lambda}.first_piola(F);
  }
  TensorMat<dim> first_piola_derivative(const Mat<dim>& F, bool project_to_psd) const {
    return model == SolidModel::neo_hookean ? NeoHookean<dim>{mu, lambda}.first_piola_derivative(F, project_to_psd)
                                            : FixedCorotated<dim>{mu, lambda}.first_piola_derivative(F, project_to_psd);
  }

  // The same from the rotation-variant SVD of F, which a caller may keep from one
  // evaluation to the next (the Newton step: energy, then gradient and stiffness at the
  // accepted state). The fixed-corotated energy and stress are functions of it; the
  // neo-Hookean ones are not (energy_needs_svd() false), its stiffness is.
  bool energy_needs_svd() const { return model == SolidModel::fixed_corotated; }
  Real energy_density(const RotationVariantSvd<dim>& svd) const { return FixedCorotated<dim>{mu, lambda}.energy_density(svd); }
  Mat<dim> first_piola(const RotationVariantSvd<dim>& svd) const { return FixedCorotated<dim>{mu, lambda}.first_piola(svd); }
  TensorMat<dim> first_piola_derivative(const RotationVariantSvd<dim>& svd, bool project_to_psd) const {
    return model == SolidModel::neo_hookean ? NeoHookean<dim>{mu, lambda}.first_piola_derivative(svd, project_to_psd)
                                            : FixedCorotated<dim>{mu, lambda}.first_piola_derivative(svd, project_to_psd);
  }
};

inline SolidModel solid_model_from_name(const std::string& name) {
  return name == "neo_hookean" ? SolidModel::neo_hookean : SolidModel::fixed_corotated;
}

}  // namespace iqmpm
