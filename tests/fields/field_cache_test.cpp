// Field cache: the second compute with the same image and parameters loads the stored field
// (identical vectors, no solve), a changed voxel or parameter misses, a corrupt entry is
// recomputed, every cacheable field type round-trips its state, and the key is the canonical
// JSON of the options (a default spelt out hits the same entry).
#include "fields/field_cache.h"
#include "fields/gvf.h"
#include "fields/registry.h"
#include "framework/core/errors.h"

#include <cmath>
#include <filesystem>
#include <set>
#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

namespace dsnake {
namespace {

std::string fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("dsnake_cache_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  return dir.string();
}

// A "field" object with "cache", as an experiment file gives it.
template <int D>
std::unique_ptr<ExternalField<D>> make(const std::string& json) {
  const nlohmann::json j = nlohmann::json::parse(json);
  JsonReader reader(j, "exp.json", "field");
  return build_field<D>(read_field_spec<D>(reader));
}

Image<2> disk(float inside) {
  Grid<2> grid;
  grid.size = GridIndex<2>(40, 36);
  grid.spacing = Point<2>(1.0, 1.2);
  Image<2> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = (grid.to_physical(grid.index(l)) - Point<2>(19, 21)).norm() < 9 ? inside : 0.0f;
  return image;
}

TEST(FieldCache, SecondComputeLoadsIdenticalField) {
  const std::string dir = fresh_dir("gvf");
  const std::string json = R"({"type": "gvf", "mu": 0.2, "cache": ")" + dir + R"("})";
  const Image<2> image = disk(1.0f);
  auto first = make<2>(json);
  auto* cached = dynamic_cast<CachedField<2>*>(first.get());
  ASSERT_NE(cached, nullptr);
  first->compute(image);
  EXPECT_FALSE(cached->loaded_from_cache());
  ASSERT_TRUE(std::filesystem::exists(cached->entry_path()));
  const auto& solved = dynamic_cast<const GvfField<2>&>(cached->field());
  EXPECT_GT(solved.stats().iterations, 0);

  auto second = make<2>(json);
  auto* again = dynamic_cast<CachedField<2>*>(second.get());
  second->compute(image);
  EXPECT_TRUE(again->loaded_from_cache());
  EXPECT_EQ(again->entry_path(), cached->entry_path());
  // The loaded field is bit-identical, and the stored solver statistics come with it.
  ASSERT_EQ(second->vectors().data(), first->vectors().data());
  EXPECT_EQ(dynamic_cast<const GvfField<2>&>(again->field()).stats().iterations, solved.stats().iterations);
  EXPECT_EQ(second->force(Point<2>(10.3, 7.7), Point<2>::Zero()), first->force(Point<2>(10.3, 7.7), Point<2>::Zero()));

  // A changed voxel, a changed parameter: misses (new entries).
  Image<2> changed = image;
  changed[5] += 0.5f;
  auto third = make<2>(json);
  third->compute(changed);
  EXPECT_FALSE(dynamic_cast<CachedField<2>*>(third.get())->loaded_from_cache());
  auto fourth = make<2>(R"({"type": "gvf", "mu": 0.3, "cache": ")" + dir + R"("})");
  fourth->compute(image);
  EXPECT_FALSE(dynamic_cast<CachedField<2>*>(fourth.get())->loaded_from_cache());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 3);
  std::filesystem::remove_all(dir);
}

// compute_releasing through the cache: on a miss the wrapped field releases the image as it
// would without a cache (GVF drops its voxels) and the entry is stored; on a hit the entry
// loads; both give the bits of a plain compute.
TEST(FieldCache, ComputeReleasingReleasesTheImageOnAMissAndLoadsOnAHit) {
  const std::string dir = fresh_dir("releasing");
  const std::string json = R"({"type": "gvf", "mu": 0.2, "cache": ")" + dir + R"("})";
  auto plain = make<2>(R"({"type": "gvf", "mu": 0.2})");
  plain->compute(disk(1.0f));
  for (int pass = 0; pass < 2; ++pass) {
    auto field = make<2>(json);
    auto* cached = dynamic_cast<CachedField<2>*>(field.get());
    ASSERT_NE(cached, nullptr);
    Image<2> image = disk(1.0f);
    compute_releasing(*field, std::move(image));
    EXPECT_EQ(cached->loaded_from_cache(), pass == 1);
    if (pass == 0) {
      EXPECT_TRUE(image.data().empty()) << "the image is released on a miss";
    }
    EXPECT_TRUE(std::filesystem::exists(cached->entry_path()));
    ASSERT_EQ(field->vectors().num_voxels(), plain->vectors().num_voxels());
    for (int64_t l = 0; l < plain->vectors().num_voxels(); ++l)
      for (int a = 0; a < 2; ++a)
        ASSERT_EQ(field->vectors().at(l)[a], plain->vectors().at(l)[a]) << "voxel " << l << ", pass " << pass;
  }
  std::filesystem::remove_all(dir);
}

TEST(FieldCache, CorruptEntryIsRecomputed) {
  const std::string dir = fresh_dir("corrupt");
  const std::string json = R"({"type": "gvf", "cache": ")" + dir + R"("})";
  const Image<2> image = disk(1.0f);
  auto first = make<2>(json);
  first->compute(image);
  const std::string path = dynamic_cast<CachedField<2>*>(first.get())->entry_path();
  std::ofstream(path, std::ios::binary | std::ios::trunc) << "dsnake-gvf-1 truncated";
  auto second = make<2>(json);
  testing::internal::CaptureStderr();
  second->compute(image);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("does not fit"), std::string::npos);
  EXPECT_FALSE(dynamic_cast<CachedField<2>*>(second.get())->loaded_from_cache());
  EXPECT_EQ(second->vectors().data(), first->vectors().data());
  std::filesystem::remove_all(dir);
}

TEST(FieldCache, EveryCacheableTypeRoundTrips3d) {
  Grid<3> grid;
  grid.size = GridIndex<3>(20, 18, 10);
  grid.spacing = Point<3>(1, 1, 2);
  Image<3> image(grid);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = (grid.to_physical(grid.index(l)) - Point<3>(10, 9, 9)).norm() < 6 ? 1.0f : 0.0f;
  const std::string dir = fresh_dir("types");
  for (const std::string type : {"gvf", "ddgvf", "vfc", "distance"}) {
    const std::string json = R"({"type": ")" + type + R"(", "cache": ")" + dir + R"("})";
    auto a = make<3>(json), b = make<3>(json);
    a->compute(image);
    b->compute(image);
    EXPECT_TRUE(dynamic_cast<CachedField<3>*>(b.get())->loaded_from_cache()) << type;
    ASSERT_EQ(a->vectors().data(), b->vectors().data()) << type;
    const Point<3> x(7.3, 8.1, 5.5), n(0.6, -0.8, 0.0);
    EXPECT_EQ(a->force(x, n), b->force(x, n)) << type;
    EXPECT_EQ(a->has_potential(), b->has_potential()) << type;
    if (a->has_potential()) {
      EXPECT_EQ(a->potential(x), b->potential(x)) << type;
    }
  }
  std::filesystem::remove_all(dir);
}

// The optional interfaces: exactly the fields with a stored state are cacheable, the diffused
// fields are large; a cache around a field that is not cacheable stores no entry and computes
// every time, and forwards a large field's hints (DDGVF's told largest |F| without its vectors).
TEST(FieldCache, OptionalInterfacesAreWhatTheFieldImplements) {
  const std::set<std::string> cacheable{"gvf", "ddgvf", "vfc", "distance"}, large{"gvf", "ddgvf"};
  for (const std::string& type : field_registry<2>().names()) {
    if (!field_registry<2>().entry(type).make_default) continue;  // a refusal
    auto field = field_registry<2>().entry(type).make_default();
    EXPECT_EQ(as_cacheable(*field) != nullptr, cacheable.count(type) == 1) << type;
    EXPECT_EQ(as_large(*field) != nullptr, large.count(type) == 1) << type;
  }

  const std::string dir = fresh_dir("plain");
  const Image<2> image = disk(1.0f);
  auto plain = make<2>(R"({"type": "gradient", "cache": ")" + dir + R"("})");
  auto* cached = dynamic_cast<CachedField<2>*>(plain.get());
  ASSERT_NE(cached, nullptr);
  ASSERT_EQ(as_cacheable(cached->field()), nullptr);
  plain->compute(image);
  EXPECT_FALSE(cached->loaded_from_cache());
  EXPECT_EQ(cached->save_state(), "");
  EXPECT_FALSE(std::filesystem::exists(cached->entry_path()));
  EXPECT_EQ(field_voxels(*plain), image.num_voxels());
  EXPECT_TRUE(std::isnan(cached->largest_vector_norm()));

  auto ddgvf = make<2>(R"({"type": "ddgvf", "cache": ")" + dir + R"("})");
  ddgvf->compute(image);
  const auto* inner = as_large(dynamic_cast<CachedField<2>&>(*ddgvf).field());
  ASSERT_NE(inner, nullptr);
  EXPECT_FALSE(std::isnan(inner->largest_vector_norm()));
  EXPECT_EQ(told_largest_vector_norm(*ddgvf), inner->largest_vector_norm());
  EXPECT_EQ(field_voxels(*ddgvf), inner->num_voxels());
  std::filesystem::remove_all(dir);
}

// "cache_compression": "zlib" stores a smaller entry that loads to the same bits; a raw entry
// of the same field is read by a compressing cache and the other way round (one key for both),
// and a deflated entry whose stream is cut short is recomputed.
TEST(FieldCache, DeflatedEntriesAreSmallerAndLoadToTheSameBits) {
  const Image<2> image = disk(1.0f);
  const std::string raw_dir = fresh_dir("raw"), zip_dir = fresh_dir("zip");
  auto raw = make<2>(R"({"type": "gvf", "cache": ")" + raw_dir + R"("})");
  auto zip = make<2>(R"({"type": "gvf", "cache": ")" + zip_dir + R"(", "cache_compression": "zlib"})");
  raw->compute(image);
  zip->compute(image);
  const std::string raw_path = dynamic_cast<CachedField<2>*>(raw.get())->entry_path();
  const std::string zip_path = dynamic_cast<CachedField<2>*>(zip.get())->entry_path();
  EXPECT_EQ(std::filesystem::path(raw_path).filename(), std::filesystem::path(zip_path).filename());
  EXPECT_LT(std::filesystem::file_size(zip_path), std::filesystem::file_size(raw_path));
  // An uncompressing cache reads the deflated entry.
  auto load = make<2>(R"({"type": "gvf", "cache": ")" + zip_dir + R"("})");
  load->compute(image);
  EXPECT_TRUE(dynamic_cast<CachedField<2>*>(load.get())->loaded_from_cache());
  EXPECT_EQ(load->vectors().data(), raw->vectors().data());
  // A cut stream does not fit: recomputed, same bits.
  const auto size = std::filesystem::file_size(zip_path);
  std::filesystem::resize_file(zip_path, size / 2);
  auto cut = make<2>(R"({"type": "gvf", "cache": ")" + zip_dir + R"("})");
  testing::internal::CaptureStderr();
  cut->compute(image);
  EXPECT_NE(testing::internal::GetCapturedStderr().find("does not fit"), std::string::npos);
  EXPECT_FALSE(dynamic_cast<CachedField<2>*>(cut.get())->loaded_from_cache());
  EXPECT_EQ(cut->vectors().data(), raw->vectors().data());
  EXPECT_THROW(make<2>(R"({"type": "gvf", "cache": "x", "cache_compression": "lzma"})"), InputError);
  std::filesystem::remove_all(raw_dir);
  std::filesystem::remove_all(zip_dir);
}

TEST(FieldCache, KeyDependsOnGridAndParameters) {
  Image<2> a = disk(1.0f), b = a;
  Grid<2> g = b.grid();
  g.origin = Point<2>(0.5, 0);
  Image<2> shifted(g);
  shifted.data() = a.data();
  EXPECT_EQ(field_cache_key(a, "gvf", "{}"), field_cache_key(b, "gvf", "{}"));
  EXPECT_NE(field_cache_key(a, "gvf", "{}"), field_cache_key(shifted, "gvf", "{}"));
  EXPECT_NE(field_cache_key(a, "gvf", "{}"), field_cache_key(a, "ddgvf", "{}"));
  EXPECT_NE(field_cache_key(a, "gvf", R"({"mu":0.2})"), field_cache_key(a, "gvf", R"({"mu":0.3})"));
}

TEST(FieldCache, DefaultsSpeltOutHitTheSameEntry) {
  const std::string dir = fresh_dir("canonical");
  const Image<2> image = disk(1.0f);
  auto implicit = make<2>(R"({"type": "gvf", "cache": ")" + dir + R"("})");
  implicit->compute(image);
  auto spelt = make<2>(R"({"cache": ")" + dir + R"(", "mu": 0.2, "type": "gvf", "sigma": 1.0, "solver": "multigrid"})");
  spelt->compute(image);
  EXPECT_TRUE(dynamic_cast<CachedField<2>*>(spelt.get())->loaded_from_cache());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
  std::filesystem::remove_all(dir);
}

TEST(FieldCache, SpecHoldsEveryOptionAndTheFolder) {
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "ddgvf", "mu": 0.1, "cache": "c"})");
  JsonReader reader(j, "exp.json", "field");
  const FieldSpec<3> spec = read_field_spec<3>(reader);
  ASSERT_TRUE(spec.cache.cache);
  EXPECT_EQ(*spec.cache.cache, "c");
  EXPECT_EQ(spec.field.type, "ddgvf");
  EXPECT_EQ(spec.field.options.dump(),
            R"({"sigma":1.0,"normalize":true,"mu":0.1,"solver":"multigrid","tolerance":0.0001,"iterations":0,)"
            R"("time_step":0.0,"polarity":"dark_inside"})");
  // Without a folder: the plain field, no wrapper.
  const nlohmann::json plain = nlohmann::json::parse(R"({"type": "gvf"})");
  JsonReader rp(plain, "exp.json", "field");
  auto field = build_field<2>(read_field_spec<2>(rp));
  EXPECT_EQ(dynamic_cast<CachedField<2>*>(field.get()), nullptr);
  EXPECT_NE(dynamic_cast<GvfField<2>*>(field.get()), nullptr);
  const auto schema = field_common_schema_properties();
  ASSERT_TRUE(schema.contains("cache"));
  EXPECT_EQ(schema["cache"]["type"], "string");
}

TEST(FieldCache, RejectsEmptyCacheAndRegistryAloneRejectsCache) {
  const nlohmann::json j = nlohmann::json::parse(R"({"type": "gvf", "cache": ""})");
  JsonReader reader(j, "exp.json", "field");
  try {
    read_field_spec<2>(reader);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.cache"), std::string::npos);
  }
  // The registry knows the fields' own keys only: "cache" is unknown there.
  const nlohmann::json k = nlohmann::json::parse(R"({"type": "gvf", "cache": "dir"})");
  JsonReader rk(k, "exp.json", "field");
  try {
    field_registry<2>().create(rk);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field.cache"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dsnake
