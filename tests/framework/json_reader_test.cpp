#include "framework/core/json_reader.h"

#include "framework/core/errors.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace dsnake {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(JsonReader, ReadsTypedValuesAndRejectsUnknownKeys) {
  const auto j = nlohmann::json::parse(R"({"alpha": 0.5, "n": 3, "on": true, "name": "x", "v": [1, 2], "extra": 1})");
  JsonReader r(j, "exp.json", "energies[1]");
  double alpha = 0;
  int n = 0;
  bool on = false;
  std::string name;
  Point<2> v;
  r.read("alpha", alpha);
  r.read("n", n);
  r.read("on", on);
  r.read("name", name);
  r.read<2>("v", v);
  EXPECT_EQ(alpha, 0.5);
  EXPECT_EQ(n, 3);
  EXPECT_TRUE(on);
  EXPECT_EQ(name, "x");
  EXPECT_EQ(v, Point<2>(1, 2));
  EXPECT_EQ(error_of([&] { r.finish(); }), "exp.json: energies[1].extra: unknown key");
}

TEST(JsonReader, WrongTypesAndRangesNameThePath) {
  const auto j = nlohmann::json::parse(R"({"alpha": "high", "n": 2.5, "beta": -1})");
  JsonReader r(j, "exp.json", "energies[0]");
  double alpha = 0, beta = 0;
  int n = 0;
  EXPECT_EQ(error_of([&] { r.read("alpha", alpha); }), "exp.json: energies[0].alpha: expected a number, found string");
  EXPECT_NE(error_of([&] { r.read("n", n); }).find("energies[0].n: expected an integer"), std::string::npos);
  r.read("beta", beta);
  EXPECT_EQ(error_of([&] { r.expect(beta >= 0, "beta", "must be >= 0"); }), "exp.json: energies[0].beta: must be >= 0");
  EXPECT_EQ(error_of([&] { r.require("gamma", beta); }), "exp.json: energies[0].gamma: is required");
  const auto arr = nlohmann::json::parse("[1]");
  EXPECT_EQ(error_of([&] { JsonReader(arr, "f.json", "field"); }), "f.json: field: expected a JSON object");
}

}  // namespace
}  // namespace dsnake
