// SPDX-License-Identifier: GPL-3.0-or-later
// The reports' JSON writer: layout, escaping, non-finite numbers, embedding another report.
#include "iires/detail/json.hpp"
#include "iires/preprocess.hpp"
#include "iires/register/registration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

using iires::detail::JsonWriter;

TEST(Json, BlockAndInlineLayout) {
  JsonWriter j;
  j.beginObject(true).member("n", 3).member("ok", true).key("inner").beginObject().member("a", 0.5).member("b", -2);
  j.endObject().array("list", std::vector<int>{1, 2}).array("empty", std::vector<double>{}).endObject();
  EXPECT_EQ(j.str(), "{\n  \"n\": 3,\n  \"ok\": true,\n  \"inner\": {\"a\": 0.5, \"b\": -2},\n  \"list\": [1, 2],\n"
                     "  \"empty\": []\n}");
}

TEST(Json, NonFiniteNumbersAreNull) {
  JsonWriter j;
  j.beginObject().member("nan", std::nan("")).member("inf", std::numeric_limits<double>::infinity());
  j.member("minus_inf", -std::numeric_limits<double>::infinity()).endObject();
  EXPECT_EQ(j.str(), R"({"nan": null, "inf": null, "minus_inf": null})");
}

TEST(Json, StringsAndKeysAreEscaped) {
  JsonWriter j;
  j.beginObject().member("say \"hi\"", "back\\slash\nnew line\ttab\x01").endObject();
  EXPECT_EQ(j.str(), R"({"say \"hi\"": "back\\slash\nnew line\ttab\u0001"})");
}

TEST(Json, PrecisionIsSignificantDigits) {
  JsonWriter ten, twelve(12);
  ten.value(M_PI);
  twelve.value(M_PI);
  EXPECT_EQ(ten.str(), "3.141592654");
  EXPECT_EQ(twelve.str(), "3.14159265359");
  JsonWriter big;
  big.value(1e21);
  EXPECT_EQ(big.str(), "1e+21");
}

TEST(Json, EmbeddedReportIsIndentedToItsLevel) {
  JsonWriter inner;
  inner.beginObject(true).member("a", 1).endObject();
  JsonWriter outer;
  outer.beginObject(true).key("inner").embed(inner.str() + "\n").member("b", 2).endObject();
  EXPECT_EQ(outer.str(), "{\n  \"inner\": {\n    \"a\": 1\n  },\n  \"b\": 2\n}");
}

// The reports written by hand before were not JSON for a NaN (written nan) or a string with a quote.
TEST(Json, ReportsWriteNullForNaNAndEscapeStrings) {
  iires::PreprocessResult p;
  p.meanDisplacement = std::nan("");
  EXPECT_NE(p.toJson().find("\"mean_displacement\": null"), std::string::npos) << p.toJson();
  iires::reg::RegistrationResult r;
  r.ambiguityReason = "a \"quoted\" reason";
  r.rmse = std::numeric_limits<double>::infinity();
  const std::string json = r.toJson();
  EXPECT_NE(json.find(R"("ambiguity_reason": "a \"quoted\" reason")"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rmse\": null"), std::string::npos) << json;
}
