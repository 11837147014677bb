// Binary glTF of the proxy with the baked preview texture (interop.h).
// tinygltf is Debian's shared libtinygltf (its README.Debian: link the
// TinyGLTF target, no TINYGLTF_IMPLEMENTATION here).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <spdlog/spdlog.h>
#include <tiny_gltf.h>
#include <unistd.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/run_record.h"
#include "relight/cue_stage.h"
#include "relight/interop.h"
#include "relight/render_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Appends `bytes` to the buffer (4-byte aligned) and returns its bufferView.
int AddBufferView(tinygltf::Model& model, const void* bytes, size_t size, int target) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  while (data.size() % 4 != 0) data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.target = target;
  const auto* begin = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), begin, begin + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size()) - 1;
}

int AddAccessor(tinygltf::Model& model, int view, int component, int type, size_t count,
                std::vector<double> min = {}, std::vector<double> max = {}) {
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.componentType = component;
  accessor.type = type;
  accessor.count = count;
  accessor.minValues = std::move(min);
  accessor.maxValues = std::move(max);
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size()) - 1;
}

std::vector<unsigned char> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in, "glTF: cannot read the texture ", path);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

void WriteGlb(const std::string& path, const render::TriangleMesh& mesh_in, const std::string& texture_png) {
  render::TriangleMesh mesh = mesh_in;
  RELIT_REQUIRE(mesh.has_uvs(), "glTF: the mesh has no UVs");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = std::string("relit ") + RelitVersion();
  model.buffers.resize(1);

  std::vector<float> positions, normals, uvs;
  std::vector<double> lo(3, 1e300), hi(3, -1e300);
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      positions.push_back(mesh.positions[i][k]);
      normals.push_back(mesh.normals[i].normalized()[k]);
      lo[k] = std::min(lo[k], double(mesh.positions[i][k]));
      hi[k] = std::max(hi[k], double(mesh.positions[i][k]));
    }
    uvs.push_back(mesh.uvs[i].x());
    uvs.push_back(1.0f - mesh.uvs[i].y());  // glTF: v runs down from the image's top row
  }
  std::vector<uint32_t> indices;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) indices.push_back(static_cast<uint32_t>(t[k]));
  }
  const size_t n = mesh.positions.size();
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.attributes["POSITION"] = AddAccessor(
      model, AddBufferView(model, positions.data(), positions.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n, lo, hi);
  primitive.attributes["NORMAL"] = AddAccessor(
      model, AddBufferView(model, normals.data(), normals.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  primitive.attributes["TEXCOORD_0"] =
      AddAccessor(model, AddBufferView(model, uvs.data(), uvs.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
                  TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, n);
  primitive.indices = AddAccessor(
      model, AddBufferView(model, indices.data(), indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, indices.size());
  primitive.material = 0;

  // The PNG's bytes live in the binary chunk (bufferView + mimeType).
  const std::vector<unsigned char> png = ReadBytes(texture_png);
  tinygltf::Image image;
  image.name = "preview_texture";
  image.mimeType = "image/png";
  image.bufferView = AddBufferView(model, png.data(), png.size(), 0);
  model.images.push_back(image);
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);
  tinygltf::Texture texture;
  texture.source = 0;
  texture.sampler = 0;
  model.textures.push_back(texture);
  tinygltf::Material material;
  material.name = "relit_preview";
  material.pbrMetallicRoughness.baseColorTexture.index = 0;
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  // The bake holds the shading already: viewers that know the extension
  // show it as is, the others fall back to a rough dielectric.
  material.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
  model.materials.push_back(material);
  model.extensionsUsed.push_back("KHR_materials_unlit");

  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = "proxy";
  gltf_mesh.primitives.push_back(primitive);
  model.meshes.push_back(gltf_mesh);
  tinygltf::Node node;
  node.name = "proxy (relit world frame, +Z up)";
  node.mesh = 0;
  // -90 degrees about x: relit's +Z up becomes glTF's +Y up, x stays.
  node.rotation = {-std::sqrt(0.5), 0.0, 0.0, std::sqrt(0.5)};
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  const fs::path target(path);
  fs::create_directories(target.parent_path());
  const fs::path temp =
      target.parent_path() / ("." + target.filename().string() + ".tmp-" + std::to_string(::getpid()));
  tinygltf::TinyGLTF writer;
  const bool ok = writer.WriteGltfSceneToFile(&model, temp.string(), /*embedImages=*/true, /*embedBuffers=*/true,
                                              /*prettyPrint=*/false, /*writeBinary=*/true);
  if (!ok) {
    fs::remove(temp);
    Fail("glTF: could not write ", path);
  }
  fs::rename(temp, target);
}

json ExportGltf(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                BakedTexture* bake_out, ModelSet models) {
  const AssetDescription asset = DescribeWorkspace(workspace, models);
  RelitRenderer renderer(asset);
  render::TriangleMesh mesh = render::LoadMesh(asset.mesh);
  RELIT_REQUIRE(mesh.has_uvs(), "glTF export: the proxy mesh ", asset.mesh,
                " has no UVs: the reconstruct stage writes the atlas");
  const CuesFile cues = ReadCuesFile((fs::path(workspace) / "relight" / "cues" / "cues.json").string());
  BakedTexture bake = BakePreviewTexture(renderer, mesh, options, cues.samples_per_pixel);
  AtomicDir out(out_dir);
  const Image srgb = TonemapToSrgb(bake, options.bake_exposure);
  WriteImage((out.path() / "preview_texture.png").string(), srgb, PixelStorage::kUint8);
  WriteGlb((out.path() / "preview.glb").string(), mesh, (out.path() / "preview_texture.png").string());
  WriteImage((out.path() / "preview_texture.exr").string(), bake.linear);
  json views = json::array();
  for (const Camera& view : bake.views) {
    views.push_back({{"cam_from_world", ToJson(view.cam_from_world())}, {"intrinsics", ToJson(view.intrinsics())}});
  }
  size_t inside = 0, seen = 0;
  for (size_t i = 0; i < bake.inside.data().size(); ++i) {
    inside += bake.inside.data()[i] > 0;
    seen += bake.inside.data()[i] > 0 && bake.weight.data()[i] >= kSeenWeight;
  }
  const json summary = {{"folder", out.target().filename().string()},
                        {"glb", "preview.glb"},
                        {"texture", "preview_texture.png"},
                        {"texture_linear", "preview_texture.exr"},
                        {"texture_px", bake.resolution_px},
                        {"vertices", mesh.positions.size()},
                        {"triangles", mesh.triangles.size()},
                        {"views", views},
                        {"light",
                         {{"type", "uniform white environment"},
                          {"radiance", options.bake_environment_radiance * asset.flash_intensity},
                          {"unit", "the cues' light unit (cues.flash_intensity)"}}},
                        {"exposure", options.bake_exposure},
                        {"samples_per_pixel", options.bake_samples_per_pixel > 0 ? options.bake_samples_per_pixel
                                                                                 : cues.samples_per_pixel},
                        {"surface_texels", inside},
                        {"surface_texels_seen", seen},
                        {"render_s", bake.render_seconds},
                        {"unwrap_s", bake.accumulate_seconds}};
  AtomicWriteFile(out.path() / "bake.json", summary.dump(2) + "\n");
  out.Commit();
  spdlog::info("interop: preview.glb ({} vertices, {}² texture, {:.0f}% of the surface seen) -> {}",
               mesh.positions.size(), bake.resolution_px, 100.0 * seen / std::max<size_t>(1, inside),
               out.target().string());
  if (bake_out != nullptr) *bake_out = std::move(bake);
  return summary;
}

}  // namespace relit::relight
