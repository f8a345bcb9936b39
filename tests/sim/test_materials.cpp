#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "sim/base/error.h"
#include "sim/materials.h"

using namespace handson;

TEST(Materials, BuiltInTableEqualsTheAssetFileAndClassifiesCtBands) {
  const MaterialTable file = MaterialTable::load(std::string(HANDSON_SOURCE_DIR) + "/assets/materials/ct-default.csv");
  const MaterialTable def = MaterialTable::ctDefault();
  ASSERT_EQ(file.bands().size(), def.bands().size());
  for (std::size_t i = 0; i < def.bands().size(); ++i) {
    EXPECT_EQ(file.bands()[i].name, def.bands()[i].name);
    EXPECT_EQ(file.bands()[i].lower, def.bands()[i].lower);
    EXPECT_EQ(file.bands()[i].upper, def.bands()[i].upper);
    EXPECT_EQ(file.bands()[i].youngs, def.bands()[i].youngs);
    EXPECT_EQ(file.bands()[i].poisson, def.bands()[i].poisson);
    EXPECT_EQ(file.bands()[i].strainLimit, def.bands()[i].strainLimit);
  }
  auto name = [&](double hu) { return def.band(def.classify(hu)).name; };
  EXPECT_EQ(name(-1000), "air");
  EXPECT_EQ(name(-100), "fat");
  EXPECT_EQ(name(30), "fluid-and-soft-tissue");
  EXPECT_EQ(name(55), "organ-and-blood");
  EXPECT_EQ(name(300), "spongy-bone");
  EXPECT_EQ(name(1500), "compact-bone");
  EXPECT_EQ(def.band(def.classify(55)).youngs, 8e3);  // kPa in the file, Pa in the table
  EXPECT_EQ(def.band(def.classify(1500)).youngs, 15e9);
  EXPECT_EQ(def.classify(std::nan("")), 0);
}

TEST(Materials, PoissonAboveTheCapIsCappedAndReported) {
  const auto t = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson\nsoft,-inf,100,6,0.49\nbone,100,inf,1e7,0.3\n");
  EXPECT_EQ(t.band(0).poisson, kMaxPoisson);
  ASSERT_EQ(t.capped().size(), 1u);
  EXPECT_EQ(t.capped()[0], "soft");
  // Values in a gap take the nearest band.
  const auto g = MaterialTable::parse("units,hu\nname,lower,upper,youngs_kpa,poisson\na,0,10,1,0.3\nb,20,30,2,0.3\n");
  EXPECT_EQ(g.classify(-5), 0);
  EXPECT_EQ(g.classify(12), 0);
  EXPECT_EQ(g.classify(18), 1);
  EXPECT_EQ(g.classify(99), 1);
}

TEST(Materials, BadTablesAreRefusedWithTheLine) {
  const std::string head = "units,hu\nname,lower,upper,youngs_kpa,poisson\n";
  for (const std::string& bad : {std::string("name,lower\n"), std::string("units,kelvin\n"), head + "a,0,10,1\n", head + "a,10,0,1,0.3\n",
                                head + "a,0,10,-1,0.3\n", head + "a,0,10,1,0.5\n", head + "a,0,10,nan,0.3\n", head + "a,0,10,1,0.3\nb,5,20,1,0.3\n",
                                head, std::string("units,percentile\nname,lower,upper,youngs_kpa,poisson\na,0,150,1,0.3\n")}) {
    try {
      MaterialTable::parse(bad, "t.csv");
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("t.csv"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(MaterialTable::load("/nonexistent/table.csv"), Error);
}

TEST(Materials, PercentileTableResolvesAgainstTheImage) {
  const MaterialTable t = MaterialTable::load(std::string(HANDSON_SOURCE_DIR) + "/assets/materials/mri-percentile.csv");
  EXPECT_THROW(t.classify(1.0), Error);  // not resolved yet
  // An image of 10 % zeros (background) and values 1..900 uniformly.
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  Volume v(g, ScalarType::Float32);
  for (std::size_t i = 0; i < 1000; ++i) v.setValue(i, i < 100 ? 0.0f : float(i - 99));
  const MaterialTable r = t.resolve(v);
  // Body values are 1..900: the 50th percentile is ~450, the 90th ~810.
  EXPECT_NEAR(r.bands()[2].lower, 450.5, 1.0);
  EXPECT_NEAR(r.bands()[3].lower, 810.1, 1.0);
  EXPECT_EQ(r.band(r.classify(0.0)).name, "background");
  EXPECT_EQ(r.band(r.classify(600.0)).name, "soft");
  EXPECT_EQ(r.band(r.classify(850.0)).name, "soft-bright");
  EXPECT_EQ(r.band(r.classify(899.0)).name, "brightest");
  // A flat image still resolves to ordered bands.
  Volume flat(g, ScalarType::Float32);
  const MaterialTable f = t.resolve(flat);
  for (std::size_t i = 1; i < f.bands().size(); ++i) EXPECT_GE(f.bands()[i].lower, f.bands()[i - 1].upper);
}
