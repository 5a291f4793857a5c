// Tests of render/sample_pacer.h: paced occlusion sampling at rest (passes per iteration from a
// view's pass time against the median over the views held before it).
#include <gtest/gtest.h>

#include "render/sample_pacer.h"

using mds::render::SamplePacer;

namespace {
void held_view(SamplePacer& p, std::initializer_list<double> pass_ms) {
  for (double v : pass_ms) p.observe(v);
  p.new_view();
}
}  // namespace

TEST(SamplePacer, FullPassesUntilOtherViewsWereMeasured) {
  SamplePacer p;
  EXPECT_EQ(p.passes(4, 100.0), 4u);  // no history
  // A single held view whose passes grow as its data streams in keeps every pass.
  for (double v : {2.0, 4.0, 8.0, 16.0, 32.0}) {
    p.observe(v);
    EXPECT_EQ(p.passes(4, v), 4u);
  }
  p.new_view();
  EXPECT_EQ(p.reference_ms(), 0.0);  // one view: kMinViews is 2
  p.new_view();                      // a view without iterations at rest adds nothing
  EXPECT_EQ(p.reference_ms(), 0.0);
  held_view(p, {10.0, 12.0, 12.0});
  EXPECT_DOUBLE_EQ(p.reference_ms(), 10.0);  // medians 8 and 12
  EXPECT_EQ(p.passes(4, -1.0), 4u);          // the view not measured yet
  EXPECT_EQ(p.passes(4, 0.0), 4u);
}

TEST(SamplePacer, ExpensiveViewsRunFewerPassesNeverNone) {
  SamplePacer p;
  held_view(p, {8.0, 8.0});
  held_view(p, {12.0});
  EXPECT_DOUBLE_EQ(p.reference_ms(), 10.0);
  EXPECT_EQ(p.passes(4, 10.0), 4u);
  EXPECT_EQ(p.passes(4, 12.5), 4u);   // within the slack: 4 * 1.25 * 10 / 12.5 = 4
  EXPECT_EQ(p.passes(4, 13.0), 3u);   // floor(3.85)
  EXPECT_EQ(p.passes(4, 25.0), 2u);   // 2 passes of 25 ms: about the 4 usual ones
  EXPECT_EQ(p.passes(4, 40.0), 1u);
  EXPECT_EQ(p.passes(4, 1e9), 1u);    // never below one pass
  EXPECT_EQ(p.passes(4, 1.0), 4u);    // never above full
  EXPECT_EQ(p.passes(1, 40.0), 1u);
  EXPECT_EQ(p.passes(0, 40.0), 1u);   // full taken as 1
}

TEST(SamplePacer, ReferenceIsTheMedianOfTheLastViews) {
  SamplePacer p;
  for (size_t i = 0; i < SamplePacer::kHistory; ++i) held_view(p, {100.0});
  for (size_t i = 0; i < SamplePacer::kHistory / 2 + 1; ++i) held_view(p, {10.0, -5.0, 0.0});  // <= 0 ignored
  EXPECT_DOUBLE_EQ(p.reference_ms(), 10.0);  // the oldest views left the history
  SamplePacer even;
  for (double v : {1.0, 2.0, 3.0, 4.0}) held_view(even, {v, v, 100.0 * v});  // each view's median is v
  EXPECT_DOUBLE_EQ(even.reference_ms(), 2.5);
}
