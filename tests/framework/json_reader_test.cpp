#include "framework/core/json_reader.h"

#include "framework/core/errors.h"
#include "framework/core/json_text.h"

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

// Found by fuzzing: a number past double's range is our one-line error, not nlohmann's
// out_of_range; text that is not UTF-8 is refused before nlohmann's dump() can throw on it.
TEST(JsonText, NumberOverflowIsAnInputErrorAndUtf8IsChecked) {
  EXPECT_EQ(error_of([] { parse_json_text("{\"seed\": 5.5555E+555}", "exp.json"); }),
            "exp.json: JSON number out of range: number overflow parsing '5.5555E+555'");
  EXPECT_EQ(error_of([] { parse_ordered_json_text("[7e777]", "sweep.json"); }),
            "sweep.json: JSON number out of range: number overflow parsing '7e777'");
  EXPECT_TRUE(is_valid_utf8("plain ASCII, caf\xc3\xa9, \xe2\x82\xac, \xf0\x9f\x90\x8d"));
  for (const char* bad : {"\xff", "a\xc3", "\xc0\xaf" /* overlong '/' */, "\xed\xa0\x80" /* surrogate */,
                          "\xf4\x90\x80\x80" /* past U+10FFFF */, "\xe2\x82"})
    EXPECT_FALSE(is_valid_utf8(bad)) << bad;
}

// A key twice in one object is refused with its path (nlohmann would keep the last silently);
// the same key in two objects, or in the objects of an array, is not a duplicate.
TEST(JsonText, ADuplicateKeyIsRefusedWithItsPath) {
  EXPECT_EQ(error_of([] { parse_json_text("{\"seed\": 1, \"seed\": 2}", "exp.json"); }),
            "exp.json: seed: the key appears twice in its object (JSON leaves which one counts undefined)");
  EXPECT_EQ(error_of([] {
              parse_ordered_json_text(
                  "{\"energies\": [{\"type\": \"a\"}, 3, [], {\"type\": \"b\", \"weight\": 1, \"weight\": 2}]}", "exp.json");
            }),
            "exp.json: energies[3].weight: the key appears twice in its object (JSON leaves which one counts undefined)");
  EXPECT_EQ(error_of([] {
              parse_json_text("{\"a\": {\"x\": 1}, \"b\": {\"x\": 1}, \"c\": [{\"x\": 1}, {\"x\": 2}], \"x\": 0}", "exp.json");
            }),
            "");
}

}  // namespace
}  // namespace dsnake
