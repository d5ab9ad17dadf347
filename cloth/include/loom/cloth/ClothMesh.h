#pragma once
// ClothMesh: immutable, shareable topology and rest geometry of one cloth (docs/architecture.md, "The cloth
// core"). Built once from a grid or an OBJ file, validated once; the runtime never changes it.
#include <memory>
#include <string>

#include "loom/cloth/Types.h"

namespace loom::cloth {

// Which role a spring plays. Structural/shear/bend come from the Provot grid topology; edge/hinge from
// arbitrary triangle meshes (docs/references.md, "Cloth models").
enum class SpringKind { kStructural, kShear, kBend, kEdge, kHinge };
const char* to_string(SpringKind kind);

struct SpringDef {
  int i = 0, j = 0;
  double rest_length = 0.0;  // m
  SpringKind kind = SpringKind::kStructural;
  Vec2 rest_uv_dir{1.0, 0.0};  // unit direction in material (warp/weft) space: x = weft (u), y = warp (v)
  double area = 0.0;           // m², the cloth area this spring stands for (for resolution-independent k)
  double row_share = 1.0;      // grids: 0.5 for structural/bend springs along the boundary (half a row)
};

// An interior edge (e0, e1) with the two vertices opposite it (o0 in the first triangle, o1 in the second).
struct Hinge {
  int e0 = 0, e1 = 0, o0 = 0, o1 = 0;
};

struct Edge {
  int i = 0, j = 0;
};

// Material frame of one triangle at rest: warp and weft as unit vectors in 3D, and the triangle's vertices
// in that frame (metres, true rest lengths: x along weft, y along warp). Baraff-Witkin's (u, v).
struct TriangleFrame {
  Vec3 weft = Vec3::UnitX(), warp = Vec3::UnitY();
  std::array<Vec2, 3> rest_uv{};  // m
};

// Orientation of a grid: the plane it lies in at rest.
enum class GridPlane { kXY, kXZ, kYZ };

struct GridSpec {
  double size_u = 1.0, size_v = 1.0;  // m, along the first and second in-plane axis
  int nodes_u = 17, nodes_v = 17;     // nodes per side (>= 2)
  GridPlane plane = GridPlane::kXZ;   // kXZ: horizontal sheet (y up)
  Vec3 origin = Vec3::Zero();         // m, position of node (0, 0)
};

class ClothMesh {
 public:
  // A regular grid, each cell split in two triangles with alternating diagonals; springs in Provot's
  // topology: structural (i±1), shear (both diagonals), bend (i±2). Warp runs along v, weft along u.
  static std::shared_ptr<const ClothMesh> grid(const GridSpec& spec);
  // An arbitrary triangle mesh. `corner_uvs` (texture coordinates per triangle corner, so seams are fine)
  // give the warp/weft directions: weft along +u, warp along +v. Empty `corner_uvs`: the frame comes from the
  // mesh's best-fit plane (PCA), weft along its first axis. Throws loom::Error naming `source` on degenerate
  // triangles, non-manifold edges, out-of-range indices or non-finite coordinates.
  static std::shared_ptr<const ClothMesh> from_triangles(Vec3s positions, std::vector<Tri> triangles,
                                                         std::vector<std::array<Vec2, 3>> corner_uvs,
                                                         const std::string& source);
  // Reads an OBJ file (v, vt, f; polygons are fan-split into triangles), then x -> scale * x + translate.
  // Errors name the file and line.
  static std::shared_ptr<const ClothMesh> from_obj(const std::string& path, double scale = 1.0,
                                                   const Vec3& translate = Vec3::Zero());

  int num_vertices() const { return static_cast<int>(rest_positions_.size()); }
  int num_triangles() const { return static_cast<int>(triangles_.size()); }
  const Vec3s& rest_positions() const { return rest_positions_; }
  const std::vector<TriangleFrame>& triangle_frames() const { return frames_; }
  const std::vector<Tri>& triangles() const { return triangles_; }
  const std::vector<Edge>& edges() const { return edges_; }
  const std::vector<Hinge>& hinges() const { return hinges_; }
  const std::vector<double>& triangle_rest_areas() const { return tri_area_; }  // m²
  const std::vector<double>& vertex_areas() const { return vertex_area_; }  // m², a third of each triangle
  const std::vector<SpringDef>& springs() const { return springs_; }
  // Springs whose strain is reported as "edge strain": structural springs on grids, all edges otherwise.
  const std::vector<int>& strain_springs() const { return strain_springs_; }
  bool is_grid() const { return grid_nodes_u_ > 0; }
  // Grid node index of (iu, iv); only for grids.
  int grid_index(int iu, int iv) const { return iv * grid_nodes_u_ + iu; }
  int grid_nodes_u() const { return grid_nodes_u_; }
  int grid_nodes_v() const { return grid_nodes_v_; }
  double total_area() const;

 private:
  ClothMesh() = default;
  void build_topology(const std::string& source);  // edges, hinges, areas; validates manifoldness
  void build_frames(const std::vector<std::array<Vec2, 3>>& corner_uvs);  // per-triangle warp/weft frames
  void build_mesh_springs();  // edge + hinge springs for arbitrary meshes

  Vec3s rest_positions_;
  std::vector<TriangleFrame> frames_;
  std::vector<Tri> triangles_;
  std::vector<Edge> edges_;
  std::vector<Hinge> hinges_;
  std::vector<double> tri_area_;
  std::vector<double> vertex_area_;
  std::vector<SpringDef> springs_;
  std::vector<int> strain_springs_;
  int grid_nodes_u_ = 0, grid_nodes_v_ = 0;
};

}  // namespace loom::cloth
