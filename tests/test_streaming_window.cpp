// Tests of the adaptive read window of the streaming cache (streaming/read_window.h): additive
// increase / multiplicative decrease at rest, an opened window kept across views while the
// camera moves.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "streaming/read_window.h"

namespace {

using mds::streaming::ReadWindow;
using mds::streaming::ReadWindowSettings;
using mds::streaming::screen_share;

// Runs `frames` frames of a view in which every frame has arrivals and no waste.
void calm(ReadWindow& w, int frames) {
  for (int k = 0; k < frames; ++k) w.end_frame(2, 0);
}

TEST(StreamingWindow, HeldViewsStartSmallAndGrowAdditively) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 3, .cap = 64});
  w.new_view();
  EXPECT_FALSE(w.moving());
  EXPECT_EQ(w.size(), 4u);
  calm(w, 2);
  EXPECT_EQ(w.size(), 4u);  // not yet 3 calm frames
  calm(w, 1);
  EXPECT_EQ(w.size(), 8u);
  w.end_frame(0, 0);        // nothing arrived: no evidence, no growth
  calm(w, 2);
  EXPECT_EQ(w.size(), 8u);
  calm(w, 1);
  EXPECT_EQ(w.size(), 12u);
  // The next held view (the last one ran several frames) restarts at the minimum.
  w.new_view();
  EXPECT_FALSE(w.moving());
  EXPECT_EQ(w.size(), 4u);
}

TEST(StreamingWindow, WasteHalvesTheWindowButNotBelowTheMinimum) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 1, .cap = 64});
  w.new_view();
  calm(w, 3);
  EXPECT_EQ(w.size(), 16u);
  w.end_frame(5, 1);
  EXPECT_EQ(w.size(), 8u);
  w.end_frame(5, 5);
  EXPECT_EQ(w.size(), 4u);
  w.end_frame(5, 2);
  EXPECT_EQ(w.size(), 4u);
  // Waste also resets the calm count.
  calm(w, 1);
  EXPECT_EQ(w.size(), 8u);
}

TEST(StreamingWindow, AMovingCameraOpensTheWindowAndKeepsItAcrossViews) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 3, .cap = 40, .moving_waste_share = 0.0});
  w.new_view();      // first view: at rest
  w.end_frame(0, 0);
  EXPECT_EQ(w.size(), 4u);
  w.new_view();      // the previous view ran one frame: the camera moves
  EXPECT_TRUE(w.moving());
  EXPECT_EQ(w.size(), 40u);
  w.end_frame(10, 3);  // waste
  EXPECT_EQ(w.size(), 20u);
  w.new_view();        // still moving: the state is kept, not reopened
  EXPECT_TRUE(w.moving());
  EXPECT_EQ(w.size(), 20u);
  w.end_frame(10, 0);  // calm while moving: doubled at once, up to the cap
  EXPECT_EQ(w.size(), 40u);
  w.new_view();
  w.end_frame(10, 0);
  EXPECT_EQ(w.size(), 40u);
  // The camera rests (a view of several frames); the view after it starts small again.
  w.new_view();
  w.end_frame(0, 0);
  w.end_frame(0, 0);
  w.new_view();
  EXPECT_FALSE(w.moving());
  EXPECT_EQ(w.size(), 4u);
  // Moving again reopens the window.
  w.end_frame(0, 0);
  w.new_view();
  EXPECT_TRUE(w.moving());
  EXPECT_EQ(w.size(), 40u);
}

// While moving, the window halves only when at least moving_waste_share of a frame's arrivals
// were waste (the default 1/2); less is the noise of one-iteration classes and counts as calm.
// At rest any waste halves it.
TEST(StreamingWindow, WhileMovingOnlyMostlyWastedArrivalsHalveTheWindow) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 1, .cap = 40});
  EXPECT_DOUBLE_EQ(w.settings().moving_waste_share, 0.5);
  w.new_view(true);
  ASSERT_TRUE(w.moving());
  ASSERT_EQ(w.size(), 40u);
  w.end_frame(10, 4);  // 40 % waste: noise
  EXPECT_EQ(w.size(), 40u);
  w.end_frame(10, 5);  // half: halved
  EXPECT_EQ(w.size(), 20u);
  w.end_frame(10, 4);  // calm again: doubled
  EXPECT_EQ(w.size(), 40u);
  w.end_frame(1, 1);
  EXPECT_EQ(w.size(), 20u);
  // At rest a single wasted read of ten halves it.
  w.new_view(false);
  w.end_frame(0, 0);
  w.end_frame(0, 0);
  w.new_view(false);
  ASSERT_FALSE(w.moving());
  w.end_frame(10, 0);
  EXPECT_EQ(w.size(), 8u);
  w.end_frame(10, 1);
  EXPECT_EQ(w.size(), 4u);
}

// A caller that knows the camera's next views (a path replay) says the first view moves: the
// window opens at the path's first frame, not at its second.
TEST(StreamingWindow, AKnownMotionOpensTheWindowAtTheFirstView) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 3, .cap = 40});
  w.new_view(/*known_moving=*/true);
  EXPECT_TRUE(w.moving());
  EXPECT_EQ(w.size(), 40u);
  w.end_frame(10, 6);  // mostly waste (ReadWindowSettings::moving_waste_share)
  EXPECT_EQ(w.size(), 20u);
  w.new_view(true);  // still moving: the state is kept
  EXPECT_EQ(w.size(), 20u);
  // The path holds its camera: a view of several frames, then a known rest.
  w.new_view(false);
  EXPECT_TRUE(w.moving());  // the previous view ran one frame (the rule without a hint)
  w.end_frame(0, 0);
  w.end_frame(0, 0);
  w.new_view(false);
  EXPECT_FALSE(w.moving());
  EXPECT_EQ(w.size(), 4u);
}

TEST(StreamingWindow, TheCapBoundsEverything) {
  ReadWindow w(ReadWindowSettings{.min = 4, .calm_frames = 1, .cap = 2});
  EXPECT_EQ(w.size(), 2u);
  w.new_view();
  calm(w, 5);
  EXPECT_EQ(w.size(), 2u);
  w.end_frame(1, 1);
  EXPECT_EQ(w.size(), 2u);
  ReadWindow one(ReadWindowSettings{.min = 4, .calm_frames = 3, .cap = 0});  // 0 means 1
  one.new_view();
  EXPECT_EQ(one.size(), 1u);
}

}  // namespace

// A wave's size at rest in images: the bounding disk of radius p half image heights on an image
// `aspect` wide covers pi p^2 / (4 aspect) of it, at most all of it.
TEST(StreamingWindow, ScreenShareOfABoundingDisk) {
  // A disk of radius half the image height on a square image: pi / 4 of it.
  EXPECT_NEAR(screen_share(1.0, 1.0), std::numbers::pi / 4.0, 1e-12);
  // Quadratic in the radius, inverse in the width.
  EXPECT_NEAR(screen_share(0.1, 16.0 / 9.0), std::numbers::pi * 0.01 / (4.0 * 16.0 / 9.0), 1e-15);
  EXPECT_NEAR(screen_share(0.2, 2.0) / screen_share(0.1, 2.0), 4.0, 1e-12);
  // A node around the eye covers the image once, not more.
  EXPECT_EQ(screen_share(50.0, 16.0 / 9.0), 1.0);
  EXPECT_EQ(screen_share(1e300, 1.0), 1.0);
  // Nothing on screen, and degenerate inputs.
  EXPECT_EQ(screen_share(0.0, 1.0), 0.0);
  EXPECT_EQ(screen_share(-1.0, 1.0), 0.0);
  EXPECT_EQ(screen_share(1.0, 0.0), 0.0);
  EXPECT_EQ(screen_share(std::nan(""), 1.0), 0.0);
}
