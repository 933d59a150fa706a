// The table of force models (soft/force_models.hpp): one line per model.
#include "soft/force_models.hpp"

namespace sinew {

const std::vector<const ForceModel*>& force_models() {
    // Springs before pressure: the order the integrators summed them in before the table (bit for bit).
    static const std::vector<const ForceModel*> models = {&kSpringForces, &kPressureForces, &kFemForces};
    return models;
}

}  // namespace sinew
