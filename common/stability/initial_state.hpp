#pragma once
// The particles of a case's `[initial] file` (an MLCG particle snapshot, run/particles/*.h5), read and
// checked before the level takes any of them: a file edited by hand, cut short or of another scene must
// be refused naming the file, the particle and what is allowed, not crash the set-up or the first step.
#include <vector>

#include "config/case_spec.hpp"
#include "core/particles.hpp"

namespace mlcg {

// Every particle of the file (material and density as given). Throws std::runtime_error
// "CASE:LINE: initial.file: FILE: what is wrong; what is allowed" when the datasets differ in length,
// a value is not finite, a radius is not > 0, a centre lies outside `domain` or an id is negative or
// repeated.
std::vector<ParticleInit> read_initial_particles(const config::InitialSpec& in, const config::DomainSpec& domain,
                                                 int material, double density);

}  // namespace mlcg
