// The solid step's time-integration rule (scene key solid_time_integration; the potential
// of each rule: solid/incremental_potential.h, method.md#solid-time-integration).
#pragma once

namespace iqmpm {

enum class SolidTimeIntegration {
  implicit_euler,  // the force at the step's end: first order, damps (omega dt)^2 / 2 of a vibration's amplitude a step
  midpoint,        // the force at the step's mean configuration: second order, keeps the energy
};

}  // namespace iqmpm
