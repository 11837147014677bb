#include "tools/synth/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <Eigen/Geometry>

#include "core/color.h"
#include "core/error.h"
#include "tools/synth/trajectory.h"

#ifndef RELIT_SYNTH_ASSETS_DIR
#define RELIT_SYNTH_ASSETS_DIR "tools/synth/assets"
#endif

namespace relit::synth {

namespace {

using render::Rgb;

nlohmann::json RgbJson(const Rgb& rgb) { return {rgb[0], rgb[1], rgb[2]}; }

// Material description for truth.json; `textured` maps a parameter to the
// name of its texture in SynthObject::textures.
nlohmann::json MaterialJson(const std::string& name, const render::Material& m,
                            const std::map<std::string, std::string>& textured) {
  nlohmann::json j;
  j["name"] = name;
  j["model"] =
      "Lambert diffuse + GGX microfacet (Smith height-correlated G2, Schlick Fresnel); "
      "f = diffuse/pi + specular * F(f0) * D * G2 / (4 cos_o cos_i); GGX alpha = roughness";
  auto param = [&](const std::string& key, const render::Texture& texture) {
    const auto it = textured.find(key);
    if (it != textured.end()) {
      j[key] = {{"texture", it->second}};
    } else {
      RELIT_CHECK(texture.is_constant());
      j[key] = RgbJson(texture.constant());
    }
  };
  param("diffuse_albedo", m.diffuse_albedo);
  param("specular_albedo", m.specular_albedo);
  param("roughness", m.roughness);
  j["f0"] = RgbJson(m.f0);
  return j;
}

// Loads a Y-up asset mesh, turns it Z-up, rotates it by `yaw_rad` about Z,
// scales it to `height_m` and stands it on the board centre.
render::TriangleMesh LoadStandingMesh(const std::string& path, double height_m, double yaw_rad,
                                      bool y_up = true) {
  RELIT_REQUIRE(std::filesystem::exists(path), "missing mesh ", path,
                " (for the bundled presets set assets_dir to tools/synth/assets)");
  render::TriangleMesh mesh = render::LoadMesh(path);
  RELIT_REQUIRE(!mesh.triangles.empty(), "mesh ", path, " has no triangles");
  Eigen::Affine3f transform = Eigen::Affine3f::Identity();
  transform.rotate(Eigen::AngleAxisf(static_cast<float>(yaw_rad), Eigen::Vector3f::UnitZ()));
  if (y_up) transform.rotate(Eigen::AngleAxisf(static_cast<float>(M_PI / 2), Eigen::Vector3f::UnitX()));
  mesh.Transform(transform);
  const Eigen::AlignedBox3f box = mesh.Bounds();
  RELIT_REQUIRE(box.sizes().z() > 0, "mesh ", path, " is flat along its up axis");
  const float scale = static_cast<float>(height_m) / box.sizes().z();
  const Eigen::Vector3f centre = box.center();
  Eigen::Affine3f place = Eigen::Affine3f::Identity();
  place.translate(Eigen::Vector3f(0, 0, 0.0005f));  // just above the paper
  place.scale(scale);
  place.translate(Eigen::Vector3f(-centre.x(), -centre.y(), -box.min().z()));
  mesh.Transform(place);
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  mesh.Check(path);
  return mesh;
}

// "Glossy painted patches": discs in UV space with their own low roughness
// and a strong specular layer over a semi-matte base.
void MakePaintPatches(int size_px, uint64_t seed, Image* specular, Image* roughness) {
  *specular = Image(size_px, size_px, 3, 0.25f);
  *roughness = Image(size_px, size_px, 3, 0.5f);
  uint64_t state = seed;
  for (int patch = 0; patch < 60; ++patch) {
    const double cu = UniformFromState(&state), cv = UniformFromState(&state);
    const double radius = 0.02 + 0.05 * UniformFromState(&state);
    const float patch_roughness = static_cast<float>(0.05 + 0.2 * UniformFromState(&state));
    const float patch_specular = static_cast<float>(0.7 + 0.3 * UniformFromState(&state));
    for (int y = 0; y < size_px; ++y) {
      for (int x = 0; x < size_px; ++x) {
        const double u = (x + 0.5) / size_px, v = 1.0 - (y + 0.5) / size_px;
        const double r = std::hypot(u - cu, v - cv);
        if (r > radius) continue;
        const float w = static_cast<float>(std::clamp((radius - r) / 0.006, 0.0, 1.0));
        for (int c = 0; c < 3; ++c) {
          specular->at(x, y, c) = (1 - w) * specular->at(x, y, c) + w * patch_specular;
          roughness->at(x, y, c) = (1 - w) * roughness->at(x, y, c) + w * patch_roughness;
        }
      }
    }
  }
}

SynthObject MakeObject(const std::string& name, int id, render::TriangleMesh mesh,
                       render::Material material, std::map<std::string, Image> textures,
                       const std::map<std::string, std::string>& textured) {
  SynthObject object;
  object.name = name;
  object.object_id = id;
  object.mesh = std::move(mesh);
  material.name = name;
  object.material_json = MaterialJson(name, material, textured);
  object.material = std::move(material);
  object.textures = std::move(textures);
  return object;
}

// Object `name` (id 1) with a `diffuse` texture and painted specular and
// roughness patches (MakePaintPatches), its textures named <name>_*.
SynthObject MakePaintedObject(const std::string& name, render::TriangleMesh mesh, const Image& diffuse,
                              int patches_size_px, uint64_t patches_seed) {
  Image specular, roughness;
  MakePaintPatches(patches_size_px, patches_seed, &specular, &roughness);
  render::Material material;  // f0 0.04: a dielectric
  material.diffuse_albedo = render::Texture::FromImage(diffuse, false);
  material.specular_albedo = render::Texture::FromImage(specular, false);
  material.roughness = render::Texture::FromImage(roughness, false);
  return MakeObject(name, 1, std::move(mesh), std::move(material),
                    {{name + "_diffuse_albedo", diffuse},
                     {name + "_specular_albedo", specular},
                     {name + "_roughness", roughness}},
                    {{"diffuse_albedo", name + "_diffuse_albedo"},
                     {"specular_albedo", name + "_specular_albedo"},
                     {"roughness", name + "_roughness"}});
}

void AddSpot(const std::string& assets_dir, SynthScene* scene) {
  render::TriangleMesh mesh = LoadStandingMesh(assets_dir + "/spot.obj", 0.12, 0.5);
  RELIT_REQUIRE(mesh.has_uvs(), "spot.obj has no texture coordinates");
  const Image texture = ReadImage(assets_dir + "/spot_texture.png").SelectChannels(std::vector<int>{0, 1, 2});
  const Image diffuse = DecodeImage(texture, TransferFunction::kSrgb);
  scene->objects.push_back(MakePaintedObject("spot", std::move(mesh), diffuse, 512, 0x5b07));
}

void AddBunny(const std::string& assets_dir, SynthScene* scene) {
  render::TriangleMesh mesh = LoadStandingMesh(assets_dir + "/bunny.obj", 0.12, -0.4);
  render::Material material = render::Material::Glossy(Rgb(0.55f, 0.40f, 0.26f), Rgb::Ones(), 0.12f);
  scene->objects.push_back(MakeObject("bunny", 1, std::move(mesh), std::move(material), {}, {}));
}

// Smooth colour variation in UV space (a few low-frequency sinusoids).
Image MakeColourTexture(int size_px) {
  Image image(size_px, size_px, 3);
  for (int y = 0; y < size_px; ++y) {
    for (int x = 0; x < size_px; ++x) {
      const double u = (x + 0.5) / size_px, v = 1.0 - (y + 0.5) / size_px;
      const double a = 0.5 + 0.5 * std::sin(2 * M_PI * (2 * u + 0.3)) * std::cos(2 * M_PI * (3 * v));
      const double b = 0.5 + 0.5 * std::sin(2 * M_PI * (5 * v + 1.5 * u));
      const Eigen::Vector3d colour = (1 - a) * Eigen::Vector3d(0.65, 0.55, 0.35) +
                                     a * Eigen::Vector3d(0.2, 0.35, 0.6) * (0.6 + 0.4 * b);
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = static_cast<float>(colour[c]);
    }
  }
  return image;
}

void AddCustomMesh(const CustomMesh& custom, SynthScene* scene) {
  RELIT_REQUIRE(!custom.path.empty(), "preset 'mesh' needs mesh_path (an OBJ or PLY file)");
  RELIT_REQUIRE(custom.height_m > 0.01 && custom.height_m < 0.5,
                "mesh_height_m must be in (0.01, 0.5) m, got ", custom.height_m);
  render::TriangleMesh mesh = LoadStandingMesh(custom.path, custom.height_m, 0.0, custom.y_up);
  if (!mesh.has_uvs()) {
    scene->objects.push_back(MakeObject("object", 1, std::move(mesh),
                                        render::Material::Glossy(Rgb(0.5f, 0.45f, 0.4f), Rgb::Ones(), 0.15f),
                                        {}, {}));
    return;
  }
  scene->objects.push_back(MakePaintedObject("object", std::move(mesh), MakeColourTexture(256), 256, 0xc057));
}

void AddSpheres(SynthScene* scene) {
  const float lift = 0.0005f;  // tile thickness above the paper, metres
  render::TriangleMesh tile = render::MakeQuad(Eigen::Vector3f(0, 0, lift), Eigen::Vector3f::UnitX(),
                                               Eigen::Vector3f::UnitY(), 0.06f, 0.045f);
  render::Material tile_material = render::Material::Glossy(Rgb(0.45f, 0.45f, 0.42f), Rgb::Ones(), 0.25f);
  // A 0.5 mm coaster belongs to the table: reconstruct crops everything below
  // its board-plane margin, so the mattes and the eval truth leave it out too.
  SynthObject tile_object = MakeObject("tile", 1, std::move(tile), std::move(tile_material), {}, {});
  tile_object.foreground = false;
  scene->objects.push_back(std::move(tile_object));
  const float big_radius = 0.032f, small_radius = 0.018f;
  render::Material metal = render::Material::Glossy(Rgb(0.02f, 0.02f, 0.02f), Rgb::Ones(), 0.06f);
  metal.f0 = Rgb(0.95f, 0.64f, 0.54f);  // copper-like: a strong, coloured mirror
  scene->objects.push_back(MakeObject(
      "glossy_sphere", 2,
      render::MakeSphere(Eigen::Vector3f(-0.012f, -0.004f, lift + big_radius), big_radius, 96, 48),
      std::move(metal), {}, {}));
  render::Material orange = render::Material::Glossy(Rgb(0.75f, 0.30f, 0.06f), Rgb::Constant(0.5f), 0.35f);
  scene->objects.push_back(MakeObject(
      "diffuse_sphere", 3,
      render::MakeSphere(Eigen::Vector3f(0.034f, 0.022f, lift + small_radius), small_radius, 64, 32),
      std::move(orange), {}, {}));
}

}  // namespace

std::string DefaultAssetsDir() { return RELIT_SYNTH_ASSETS_DIR; }

std::vector<std::string> PresetNames() { return {"spot", "bunny", "spheres", "mesh"}; }

SynthObject MakeBoardObject(const BoardSpec& board, double pixels_per_metre, int margin_px,
                            cv::Mat* board_image) {
  board.Check();
  // Whole pixels per square keep the printed squares exact.
  const double square_px = std::round(board.square_length_m * pixels_per_metre);
  RELIT_REQUIRE(square_px >= 8, "board texture too coarse: ", square_px, " pixels per square");
  pixels_per_metre = square_px / board.square_length_m;
  *board_image = DrawBoardImage(board, pixels_per_metre, margin_px);
  // Paper: white ~0.8, ink ~0.03 (linear albedo).
  Image albedo(board_image->cols, board_image->rows, 3);
  for (int y = 0; y < board_image->rows; ++y) {
    for (int x = 0; x < board_image->cols; ++x) {
      const float ink = 1.0f - board_image->at<uint8_t>(y, x) / 255.0f;
      for (int c = 0; c < 3; ++c) albedo.at(x, y, c) = 0.80f - 0.77f * ink;
    }
  }
  // Texture u spans the image width and v its height (v up), so image pixel
  // edge X maps to board x = X / ppm - margin and the printed top-left corner
  // (board origin) lands at world (-w/2, +h/2) as WorldFromBoard() says.
  const float half_x = static_cast<float>(0.5 * board_image->cols / pixels_per_metre);
  const float half_y = static_cast<float>(0.5 * board_image->rows / pixels_per_metre);
  render::TriangleMesh quad = render::MakeQuad(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(),
                                               Eigen::Vector3f::UnitY(), half_x, half_y);
  render::Material material = render::Material::Lambert(Rgb::Zero());
  material.diffuse_albedo = render::Texture::FromImage(albedo, false);
  SynthObject object = MakeObject("board", kBoardObjectId, std::move(quad), std::move(material),
                                  {{"board_albedo", albedo}}, {{"diffuse_albedo", "board_albedo"}});
  object.foreground = false;
  return object;
}

SynthScene BuildScene(const std::string& preset, const BoardSpec& board,
                      const std::string& assets_dir, const CustomMesh& custom) {
  SynthScene scene;
  scene.preset = preset;
  scene.board = board;
  if (preset == "spot") {
    AddSpot(assets_dir, &scene);
  } else if (preset == "bunny") {
    AddBunny(assets_dir, &scene);
  } else if (preset == "spheres") {
    AddSpheres(&scene);
  } else if (preset == "mesh") {
    AddCustomMesh(custom, &scene);
  } else {
    Fail("unknown preset '", preset, "' (known: spot, bunny, spheres, mesh)");
  }
  Eigen::AlignedBox3f bounds;
  for (const SynthObject& object : scene.objects) bounds.extend(object.mesh.Bounds());
  // Aim at half the object's height: people filming an object on a board
  // keep the board in view too.
  scene.target_world = bounds.center().cast<double>();
  scene.target_world.z() *= 0.5;
  scene.foreground_radius_m = 0.5 * bounds.sizes().norm();

  // ~3 texture pixels per millimetre, 1 cm of white paper around the print.
  const double pixels_per_metre = std::max(3000.0, 16 / board.square_length_m);
  scene.board_margin_px = static_cast<int>(std::lround(0.01 * pixels_per_metre));
  scene.objects.push_back(
      MakeBoardObject(board, pixels_per_metre, scene.board_margin_px, &scene.board_image));
  scene.board_pixels_per_metre = std::round(board.square_length_m * pixels_per_metre) /
                                 board.square_length_m;

  // Table: a dull wooden plane under the paper, large enough to fill the view.
  render::TriangleMesh table = render::MakeQuad(Eigen::Vector3f(0, 0, -0.0005f), Eigen::Vector3f::UnitX(),
                                                Eigen::Vector3f::UnitY(), 1.5f, 1.5f);
  render::Material wood = render::Material::Glossy(Rgb(0.22f, 0.14f, 0.08f), Rgb::Constant(0.3f), 0.4f);
  SynthObject table_object = MakeObject("table", kTableObjectId, std::move(table), std::move(wood), {}, {});
  table_object.foreground = false;
  scene.objects.push_back(std::move(table_object));
  return scene;
}

void SynthScene::AddTo(render::Scene* scene) const {
  for (const SynthObject& object : objects) {
    scene->AddObject(object.mesh, object.material, object.object_id);
  }
}

std::vector<int> SynthScene::ForegroundIds() const {
  std::vector<int> ids;
  for (const SynthObject& object : objects) {
    if (object.foreground) ids.push_back(object.object_id);
  }
  return ids;
}

}  // namespace relit::synth
