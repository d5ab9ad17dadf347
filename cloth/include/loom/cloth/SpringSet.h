#pragma once
// From a mesh's spring definitions and a material to per-spring stiffness, resolution-independently
// (docs/references.md, "Fabric measurement"). On grids (Provot topology, spacing du x dv):
//   shear (diagonals):       k_d = min(G, Y_min / 2)           (a grid with both diagonals has C33 = k_d)
//   bend (i, i+2):           k_b = min(576 B A_e / L⁴, (Y - k_d) / 8), A_e = du dv   (see below)
//   structural along weft:   k = Y_weft - k_d - 4 k_b          (C11 = k_s + k_d + 4 k_b), likewise warp
// On arbitrary meshes: edge springs k_e = Y(φ) sum_t A_t / l_e² (Van Gelder 1998), Y(φ) = Y_weft cos²φ +
// Y_warp sin²φ with φ the edge's angle to the weft; hinge springs like bend springs with A_e = (A1 + A2)/3.
// Bend and hinge springs: a skip-one spring across a bend of curvature κ shortens by L³κ²/24, so it has no
// stiffness at the flat state and no exact mapping to B (docs/references.md, "Cloth models", pitfall). We
// match the bending energy 1/2 B κ² A_e at κ = 1/L, the sharpest fold the spring can represent. Dihedral and
// Choi-Ko bending (later issues) are the resolution-independent models.
// Damping: c = material.damping * k.
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

std::vector<Spring> make_springs(const ClothMesh& mesh, const Material& material);

}  // namespace loom::cloth
