// The viewer's page budget: thinned to fit when --every is not given, refused naming the one that
// fits when it is.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "apps/sweep/viewer.hpp"
#include "framework/error.hpp"

namespace sweep {
namespace {

TEST(ViewerPage, KeepsEveryNthSnapshotAndTheLast) {
  EXPECT_EQ(keptSnapshots(1, 1), 1u);
  EXPECT_EQ(keptSnapshots(10, 1), 10u);
  EXPECT_EQ(keptSnapshots(10, 3), 4u);  // 0, 3, 6 and 9, the last
  EXPECT_EQ(keptSnapshots(11, 3), 5u);  // 0, 3, 6, 9 and the last, 10
  EXPECT_EQ(keptSnapshots(10, 100), 2u);
}

TEST(ViewerPage, ThinsToTheSmallestEveryThatFitsOrRefusesAGivenOne) {
  // 10 000 snapshots of 200 kB: 2 GB of page at --every 1; 500 MB holds 2 500 of them
  ViewerPage page{10000, 2e5, 8e5, 1e12};
  std::ostringstream log;
  const int every = fittingEvery(page, 0, &log);
  EXPECT_LE(static_cast<double>(keptSnapshots(10000, every)) * 2e5, kMaxViewerPageBytes);
  EXPECT_GT(static_cast<double>(keptSnapshots(10000, every - 1)) * 2e5, kMaxViewerPageBytes);
  EXPECT_NE(log.str().find("view: keeping every " + std::to_string(every) + "-th snapshot"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(fittingEvery(page, every + 3, nullptr), every + 3);
  try {
    fittingEvery(page, 2, nullptr);
    ADD_FAILURE() << "an --every whose page does not fit was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--every 2: 10000 snapshots of 200 kB each make a page "
                                         "past the 500 MB a browser opens"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--every " + std::to_string(every) + " fits"),
              std::string::npos)
        << e.what();
  }
  // the memory limit binds first when it is the smaller
  page.memory_limit = 8e7;  // 100 snapshots
  EXPECT_EQ(keptSnapshots(10000, fittingEvery(page, 0, nullptr)), 100u);
  // a small run is left whole and silent
  std::ostringstream quiet;
  EXPECT_EQ(fittingEvery(ViewerPage{50, 1e3, 4e3, 1e12}, 0, &quiet), 1);
  EXPECT_EQ(quiet.str(), "");
  // one snapshot beyond the page: nothing fits
  EXPECT_THROW(fittingEvery(ViewerPage{3, 3e8, 1.2e9, 1e12}, 0, nullptr), InputError);
}

}  // namespace
}  // namespace sweep
