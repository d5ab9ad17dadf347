// Exports read back: PC2 point caches (our reader, the documented byte layout) and glTF 2.0 morph-target
// animation (Debian's tinygltf) must reproduce the simulated positions, in process and through `loom run`.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "SymplecticSetup.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"
#include "loom/export/Exporters.h"
#include "loom/export/GltfWriter.h"
#include "loom/export/Pc2.h"

#ifdef LOOM_HAVE_TINYGLTF
#include <tiny_gltf.h>
#endif

#include "TestDir.h"

namespace loom::exporter {
namespace {

namespace fs = std::filesystem;
using cloth::Vec3;
using cloth::Vec3s;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = test::test_dir() / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Two small cloths (5x4 and 3x3 grids), one pinned at a corner, so every frame moves and differs.
cloth::Simulation make_sim() {
  cloth::SimulationSetup setup = loom::test::symplectic_setup();
  cloth::GridSpec a;
  a.nodes_u = 5;
  a.nodes_v = 4;
  cloth::ClothSetup c1;
  c1.name = "sheet one";
  c1.mesh = cloth::ClothMesh::grid(a);
  c1.material = cloth::material_preset("cotton");
  c1.pins = {cloth::PinSpec{0, {}, {}, {}}};
  cloth::GridSpec b;
  b.nodes_u = 3;
  b.nodes_v = 3;
  b.origin = Vec3(2.0, 1.0, 0.0);
  cloth::ClothSetup c2;
  c2.name = "sheet one";  // same name on purpose: files must stay distinct
  c2.mesh = cloth::ClothMesh::grid(b);
  c2.material = cloth::material_preset("cotton");
  c2.initial_velocity = Vec3(0.3, 0.0, -0.1);
  setup.cloths = {c1, c2};
  setup.substeps = 20;
  return cloth::Simulation(setup);
}

struct Recorded {
  std::vector<double> times;
  std::vector<std::vector<Vec3s>> x;  // [sample][cloth]
};

// Runs `frames` frames writing every `every`-th frame (frame 0 included) and returns what was written.
Recorded run_and_export(const fs::path& out, const std::vector<std::string>& formats, int frames, int every) {
  cloth::Simulation sim = make_sim();
  Exporters ex(out.string(), formats, sim.cloths(), every);
  Recorded r;
  auto record = [&] {
    r.times.push_back(sim.time());
    r.x.emplace_back();
    for (const auto& c : sim.cloths()) r.x.back().push_back(c->state().x);
    ex.frame(sim.time(), sim.cloths());
  };
  record();
  for (int f = 1; f <= frames; ++f) {
    sim.step_frame();
    if (f % every == 0) record();
  }
  ex.finish();
  return r;
}

// A cloth whose name is a valid file name keeps it, whatever the order: "a/b" (sanitised to a_b) never takes
// the file of the cloth named "a_b", nor of "a_b_1".
TEST(Pc2, FileNamesNeverCarryAnotherClothsName) {
  std::vector<std::unique_ptr<cloth::Cloth>> cloths;
  for (const char* name : {"a/b", "a_b", "a_b_1", "a b", "sheet", "sheet"}) {
    cloth::GridSpec g;
    g.nodes_u = g.nodes_v = 2;
    cloths.push_back(
        std::make_unique<cloth::Cloth>(name, cloth::ClothMesh::grid(g), cloth::material_preset("cotton")));
  }
  const std::vector<std::string> names = Exporters::file_names(cloths);
  const std::vector<std::string> want = {"a_b_2", "a_b", "a_b_1", "a_b_3", "sheet", "sheet_1"};
  EXPECT_EQ(names, want);
}

TEST(Pc2, RoundTripMatchesSimulatedPositions) {
  const fs::path out = fresh_dir("pc2");
  const Recorded r = run_and_export(out, {"pc2"}, 6, 2);
  ASSERT_EQ(r.times.size(), 4u);  // frames 0, 2, 4, 6
  // Distinct files for the two cloths of the same name, each with its frame-0 OBJ.
  const std::vector<std::string> names = {"sheet_one", "sheet_one_1"};
  for (size_t c = 0; c < 2; ++c) {
    const fs::path pc2 = out / "pc2" / (names[c] + ".pc2");
    ASSERT_TRUE(fs::exists(pc2)) << pc2;
    EXPECT_TRUE(fs::exists(out / "pc2" / (names[c] + ".obj")));
    const Pc2Cache cache = read_pc2(pc2.string());
    EXPECT_EQ(cache.points, static_cast<int>(r.x[0][c].size()));
    EXPECT_EQ(cache.samples, 4);
    EXPECT_EQ(cache.start_frame, 0.0f);
    EXPECT_EQ(cache.sample_rate, 2.0f);
    for (int s = 0; s < cache.samples; ++s)
      for (int i = 0; i < cache.points; ++i)
        for (int k = 0; k < 3; ++k)
          ASSERT_EQ(cache.xyz[(size_t(s) * cache.points + i) * 3 + k], static_cast<float>(r.x[s][c][i][k]))
              << "cloth " << c << " sample " << s << " vertex " << i;
    // The frames really move: sample 3 differs from sample 0.
    EXPECT_GT(std::abs(cache.xyz[(size_t(3) * cache.points + 4) * 3 + 1] - cache.xyz[4 * 3 + 1]), 1e-4);
  }
}

TEST(Pc2, HeaderBytesFollowTheFormat) {
  const fs::path p = fresh_dir("pc2_header") / "a.pc2";
  {
    Pc2Writer w(p.string(), 2, 5.0, 1.0);
    w.add_sample({Vec3(1, 2, 3), Vec3(4, 5, 6)});
    w.finish();
  }
  std::ifstream in(p, std::ios::binary);
  std::vector<unsigned char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(b.size(), 32u + 2 * 12);
  EXPECT_EQ(std::memcmp(b.data(), "POINTCACHE2\0", 12), 0);
  EXPECT_EQ(b[12], 1);  // version
  EXPECT_EQ(b[16], 2);  // points
  EXPECT_EQ(b[28], 1);  // samples
  const float five = 5.0f, six = 6.0f;
  EXPECT_EQ(std::memcmp(b.data() + 20, &five, 4), 0);         // start frame (little-endian host)
  EXPECT_EQ(std::memcmp(b.data() + 32 + 5 * 4, &six, 4), 0);  // last coordinate
}

TEST(Pc2, ReaderRejectsMalformedFiles) {
  const fs::path dir = fresh_dir("pc2_bad");
  std::ofstream(dir / "short.pc2") << "POINT";
  std::ofstream(dir / "sig.pc2") << std::string(40, 'x');
  {
    Pc2Writer w((dir / "trunc.pc2").string(), 3, 0.0, 1.0);
    w.add_sample(Vec3s(3, Vec3::Zero()));
  }
  fs::resize_file(dir / "trunc.pc2", fs::file_size(dir / "trunc.pc2") - 4);
  for (const auto& [name, words] :
       std::vector<std::pair<std::string, std::string>>{{"short.pc2", "too short"},
                                                        {"sig.pc2", "POINTCACHE2"},
                                                        {"trunc.pc2", "does not match"},
                                                        {"none.pc2", "cannot open"}}) {
    try {
      read_pc2((dir / name).string());
      ADD_FAILURE() << name << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  }
  Pc2Writer w((dir / "n.pc2").string(), 3, 0.0, 1.0);
  EXPECT_THROW(w.add_sample(Vec3s(2, Vec3::Zero())), Error);
}

#ifdef LOOM_HAVE_TINYGLTF

// The elements of accessor `index`, decoded as glTF 2.0 asks: the bufferView's data (zeros without one),
// then a sparse accessor's values substituted at its (strictly increasing, uint32 here) indices.
template <class T>
std::vector<T> accessor_data(const tinygltf::Model& m, int index, int components) {
  const tinygltf::Accessor& a = m.accessors.at(index);
  std::vector<T> out(a.count * components, T(0));
  const auto bytes_of = [&](int view, size_t offset, size_t bytes) {
    const tinygltf::BufferView& v = m.bufferViews.at(view);
    const tinygltf::Buffer& b = m.buffers.at(v.buffer);
    EXPECT_EQ(v.byteStride, 0u);  // tightly packed
    EXPECT_LE(offset + bytes, v.byteLength);
    EXPECT_LE(v.byteOffset + v.byteLength, b.data.size());
    return b.data.data() + v.byteOffset + offset;
  };
  if (a.bufferView >= 0)
    std::memcpy(out.data(), bytes_of(a.bufferView, a.byteOffset, out.size() * sizeof(T)),
                out.size() * sizeof(T));
  if (a.sparse.isSparse) {
    const size_t n = static_cast<size_t>(a.sparse.count);
    EXPECT_EQ(a.sparse.indices.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    std::vector<uint32_t> idx(n);
    std::vector<T> values(n * components);
    std::memcpy(idx.data(), bytes_of(a.sparse.indices.bufferView, a.sparse.indices.byteOffset, 4 * n), 4 * n);
    std::memcpy(values.data(),
                bytes_of(a.sparse.values.bufferView, a.sparse.values.byteOffset, values.size() * sizeof(T)),
                values.size() * sizeof(T));
    for (size_t i = 0; i < n; ++i) {
      EXPECT_TRUE(i == 0 || idx[i] > idx[i - 1]) << "sparse indices must strictly increase";
      EXPECT_LT(idx[i], a.count);
      if (idx[i] >= a.count) continue;
      for (int c = 0; c < components; ++c) out[idx[i] * components + c] = values[i * components + c];
    }
  }
  return out;
}

tinygltf::Model load_gltf(const fs::path& p) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  EXPECT_TRUE(loader.LoadASCIIFromFile(&m, &err, &warn, p.string())) << err;
  EXPECT_TRUE(err.empty()) << err;
  EXPECT_TRUE(warn.empty()) << warn;
  return m;
}

// Positions of mesh `mesh` at animation key `key`: base + the displacement of the target weighted 1.
Vec3s gltf_positions(const tinygltf::Model& m, int mesh, double key_weighting_target) {
  const tinygltf::Primitive& p = m.meshes.at(mesh).primitives.at(0);
  const std::vector<float> base = accessor_data<float>(m, p.attributes.at("POSITION"), 3);
  Vec3s x(base.size() / 3);
  for (size_t i = 0; i < x.size(); ++i) x[i] = Vec3(base[3 * i], base[3 * i + 1], base[3 * i + 2]);
  // key_weighting_target < 0: the base; else a (possibly fractional) position between targets.
  if (key_weighting_target >= 0) {
    const int t0 = static_cast<int>(key_weighting_target);
    const double a = key_weighting_target - t0;
    for (int t : {t0, t0 + 1}) {
      const double w = t == t0 ? 1.0 - a : a;
      if (w == 0.0) continue;
      const std::vector<float> d = accessor_data<float>(m, p.targets.at(t).at("POSITION"), 3);
      for (size_t i = 0; i < x.size(); ++i) x[i] += w * Vec3(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
    }
  }
  return x;
}

TEST(Gltf, MorphAnimationMatchesSimulatedPositions) {
  const fs::path out = fresh_dir("gltf");
  const Recorded r = run_and_export(out, {"gltf"}, 6, 1);
  ASSERT_EQ(r.times.size(), 7u);
  ASSERT_TRUE(fs::exists(out / "animation.bin"));
  const tinygltf::Model m = load_gltf(out / "animation.gltf");
  ASSERT_EQ(m.meshes.size(), 2u);
  ASSERT_EQ(m.nodes.size(), 2u);
  ASSERT_EQ(m.animations.size(), 1u);
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_TRUE(m.materials[0].doubleSided);
  cloth::Simulation ref = make_sim();
  for (int c = 0; c < 2; ++c) {
    const tinygltf::Primitive& p = m.meshes[c].primitives.at(0);
    ASSERT_EQ(p.targets.size(), 6u);
    // Indices are the simulation's triangles.
    const std::vector<uint32_t> idx = accessor_data<uint32_t>(m, p.indices, 1);
    const auto& tris = ref.cloths()[c]->mesh().triangles();
    ASSERT_EQ(idx.size(), 3 * tris.size());
    for (size_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(idx[3 * t + k], static_cast<uint32_t>(tris[t][k]));
    // Every key reproduces its simulated frame to float precision.
    for (size_t s = 0; s < r.times.size(); ++s) {
      const Vec3s x = gltf_positions(m, c, static_cast<double>(s) - 1.0);
      ASSERT_EQ(x.size(), r.x[s][c].size());
      for (size_t i = 0; i < x.size(); ++i)
        ASSERT_LT((x[i] - r.x[s][c][i]).norm(), 2e-6) << "frame " << s << " vertex " << i;
    }
  }
  // The animation: one weights channel per node, LINEAR, keys at the frame times, one-hot weights.
  const tinygltf::Animation& a = m.animations[0];
  ASSERT_EQ(a.channels.size(), 2u);
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(a.channels[c].target_node, c);
    EXPECT_EQ(a.channels[c].target_path, "weights");
    const tinygltf::AnimationSampler& s = a.samplers.at(a.channels[c].sampler);
    EXPECT_EQ(s.interpolation, "LINEAR");
    const std::vector<float> t = accessor_data<float>(m, s.input, 1);
    const std::vector<float> w = accessor_data<float>(m, s.output, 1);
    ASSERT_EQ(t.size(), r.times.size());
    ASSERT_EQ(w.size(), t.size() * 6);
    for (size_t k = 0; k < t.size(); ++k) {
      EXPECT_FLOAT_EQ(t[k], static_cast<float>(r.times[k]));
      for (size_t j = 0; j < 6; ++j) EXPECT_EQ(w[k * 6 + j], k >= 1 && j == k - 1 ? 1.0f : 0.0f);
    }
  }
}

// A GltfWriter run of `frames` frames of a one-triangle mesh whose vertices move every frame.
fs::path write_triangle_animation(const fs::path& dir, int frames) {
  AnimatedMesh mesh;
  mesh.name = "tri";
  mesh.vertices = 3;
  mesh.triangles = {cloth::Tri{0, 1, 2}};
  GltfWriter w((dir / "anim.gltf").string(), {mesh});
  for (int f = 0; f < frames; ++f) {
    const Vec3s x = {Vec3(0.0, 0.001 * f, 0.0), Vec3(1.0, 0.0, 0.002 * f), Vec3(0.0, 1.0, -0.001 * f)};
    w.add_frame(f / 30.0, {&x});
  }
  w.finish();
  return dir / "anim.gltf";
}

// The one-hot animation weights are a sparse accessor over zeros, so the buffer grows linearly with the
// frames: base (36 B) + indices (12 B) + per later frame a target (36 B), and per frame a time, a sparse
// index and a value (12 B). Doubling the frames roughly doubles the buffer, a dense keys x targets weights
// array (160 kB at 200 frames, 640 kB at 400) would quadruple it.
TEST(Gltf, AnimationWeightsAreASparseAccessorSoTheBufferGrowsLinearly) {
  std::uintmax_t bin[2];
  for (int i = 0; i < 2; ++i) {
    const int frames = 200 * (i + 1);
    const fs::path dir = fresh_dir("gltf_sparse_" + std::to_string(frames));
    const fs::path gltf = write_triangle_animation(dir, frames);
    bin[i] = fs::file_size(dir / "anim.bin");
    EXPECT_EQ(bin[i], 36u + 12u + 36u * (frames - 1) + 12u * frames - 8u);

    const auto j = nlohmann::json::parse(std::ifstream(gltf));
    const int out = j["animations"][0]["samplers"][0]["output"];
    const auto& a = j["accessors"][out];
    EXPECT_FALSE(a.contains("bufferView"));  // all zeros before the sparse substitution
    EXPECT_EQ(a["componentType"], 5126);
    EXPECT_EQ(a["type"], "SCALAR");
    EXPECT_EQ(a["count"], frames * (frames - 1));
    ASSERT_TRUE(a.contains("sparse"));
    EXPECT_EQ(a["sparse"]["count"], frames - 1);
    EXPECT_EQ(a["sparse"]["indices"]["componentType"], 5125);
    for (const char* part : {"indices", "values"}) {
      const auto& v = j["bufferViews"][a["sparse"][part]["bufferView"].get<int>()];
      EXPECT_EQ(v["byteLength"], 4 * (frames - 1)) << part;
      EXPECT_FALSE(v.contains("target")) << part;  // glTF: sparse views carry no target
      EXPECT_EQ(v["byteOffset"].get<size_t>() % 4, 0u) << part;
    }
    EXPECT_EQ(j["buffers"][0]["byteLength"], bin[i]);

    // Decoded, the weights are the identity pattern: key k weights target k-1 by 1, all else 0.
    const tinygltf::Model m = load_gltf(gltf);
    const std::vector<float> w = accessor_data<float>(m, out, 1);
    const size_t targets = frames - 1;
    ASSERT_EQ(w.size(), size_t(frames) * targets);
    for (size_t k = 0; k < size_t(frames); ++k)
      for (size_t t = 0; t < targets; ++t)
        ASSERT_EQ(w[k * targets + t], k >= 1 && t == k - 1 ? 1.0f : 0.0f) << k << " " << t;
    // And every key still reproduces its frame.
    const Vec3s last = gltf_positions(m, 0, frames - 2.0);
    EXPECT_NEAR(last[0].y(), 0.001 * (frames - 1), 1e-6);
    EXPECT_NEAR(last[2].z(), -0.001 * (frames - 1), 1e-6);
  }
  EXPECT_LT(double(bin[1]) / double(bin[0]), 2.1);
}

// `loom run` with every format: PC2 samples and glTF keys equal the OBJ frames of the same run.
std::vector<Vec3> read_obj_vertices(const fs::path& p) {
  std::ifstream in(p);
  std::vector<Vec3> v;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("v ", 0) == 0) {
      std::istringstream s(line.substr(2));
      Vec3 x;
      s >> x.x() >> x.y() >> x.z();
      v.push_back(x);
    }
  return v;
}

TEST(Exports, LoomRunWritesAllFormatsThatAgreeWithObjFrames) {
  const fs::path out = fresh_dir("cli");
  const std::string cmd =
      std::string(LOOM_BINARY) + " run " + LOOM_SOURCE_DIR + "/scenes/hanging_cloth.json --frames 4 --out " +
      out.string() +
      " --set 'output={\"every\": 2, \"formats\": [\"obj\", \"pc2\", \"gltf\"]}' >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Pc2Cache cache = read_pc2((out / "pc2" / "sheet.pc2").string());
  ASSERT_EQ(cache.samples, 3);  // frames 0, 2, 4
  const tinygltf::Model m = load_gltf(out / "animation.gltf");
  ASSERT_EQ(m.meshes.at(0).primitives.at(0).targets.size(), 2u);
  for (int s = 0; s < 3; ++s) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", 2 * s);
    const std::vector<Vec3> obj = read_obj_vertices(out / "frames" / name);
    ASSERT_EQ(static_cast<int>(obj.size()), cache.points);
    const Vec3s g = gltf_positions(m, 0, s - 1.0);
    for (int i = 0; i < cache.points; ++i) {
      const float* p = &cache.xyz[(size_t(s) * cache.points + i) * 3];
      ASSERT_LT((Vec3(p[0], p[1], p[2]) - obj[i]).norm(), 1e-6) << name << " vertex " << i;
      ASSERT_LT((g[i] - obj[i]).norm(), 2e-6) << name << " vertex " << i;
    }
  }
  // Only the formats asked for: a run with ["gltf"] writes no OBJ frames and removes the old PC2 folder.
  const std::string cmd2 = std::string(LOOM_BINARY) + " run " + LOOM_SOURCE_DIR +
                           "/scenes/hanging_cloth.json --frames 2 --out " + out.string() +
                           " --set 'output.formats=[\"gltf\"]' >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd2.c_str()), 0);
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00000.obj"));
  EXPECT_FALSE(fs::exists(out / "pc2"));
  EXPECT_EQ(load_gltf(out / "animation.gltf").meshes.at(0).primitives.at(0).targets.size(), 2u);
}

#endif  // LOOM_HAVE_TINYGLTF

}  // namespace
}  // namespace loom::exporter
