// The automatic mode's choice among its pilot's candidates (pick_candidate): guided only by a margin
// over unguided sampling, fewer guided vertices only by a margin over more, and caustic connections unless
// predicted to lose by a margin (take_connections).
#include <gtest/gtest.h>

#include "tools/render/integrator.h"

namespace {

using iris::kConnectMargin;
using iris::kConnectTolerance;
using iris::kGuideMargin;
using iris::kShallowMargin;
using iris::pick_candidate;
using iris::take_connections;

constexpr int kEvery = 1 << 30;

TEST(PilotChoice, UnguidedUnlessAGuidedCandidateWinsByTheMargin) {
    // Candidate 0 is unguided; ratios are efficiencies over it.
    EXPECT_EQ(pick_candidate({1.0, 0.9 * kGuideMargin}, {kEvery, 1}), 0u);
    EXPECT_EQ(pick_candidate({1.0, 1.01 * kGuideMargin}, {kEvery, 1}), 1u);
    EXPECT_EQ(pick_candidate({1.0}, {kEvery}), 0u);
}

TEST(PilotChoice, FewerGuidedVerticesNeedTheShallowMargin) {
    // unguided, first vertex, every vertex, first vertex + connections, every vertex + connections
    const std::vector<int> gv{kEvery, 1, kEvery, 1, kEvery};
    // A tie (and a 5 % lead of the first vertex) goes to every vertex.
    EXPECT_EQ(pick_candidate({1.0, 3.0, 3.0, 4.0, 4.0}, gv), 4u);
    EXPECT_EQ(pick_candidate({1.0, 3.0, 3.0, 4.2, 4.0}, gv), 4u);
    // Beyond the margin the first vertex wins.
    EXPECT_EQ(pick_candidate({1.0, 3.0, 3.0, 4.0 * kShallowMargin * 1.01, 4.0}, gv), 3u);
    // A candidate ruled out (ratio 0) is never chosen.
    EXPECT_EQ(pick_candidate({1.0, 3.0, 2.0, 0.0, 0.0}, gv), 1u);
}

TEST(PilotChoice, TheMarginDoesNotApplyWhenAllGuideAsManyVertices) {
    // The user set guide-vertices: one guided setting, with and without connections.
    EXPECT_EQ(pick_candidate({1.0, 3.0, 2.9}, {kEvery, 1, 1}), 1u);
    EXPECT_EQ(pick_candidate({1.0, 3.0, 3.1}, {kEvery, 1, 1}), 2u);
}

TEST(PilotChoice, ConnectionsStayUnlessPredictedToLoseByTheTolerance) {
    // With the light tracer running either way: a tie, a small loss and a gain all keep them.
    EXPECT_TRUE(take_connections(3.0, 3.0, true));
    EXPECT_TRUE(take_connections(3.0, 3.0 * kConnectTolerance * 0.99, true));
    EXPECT_TRUE(take_connections(4.0, 3.0, true));
    EXPECT_FALSE(take_connections(3.0, 3.0 * kConnectTolerance * 1.01, true));
}

TEST(PilotChoice, ConnectionsThatBringTheLightTracerNeedTheMargin) {
    // Without them the light tracer would not run: they must pay for it, and win by kConnectMargin.
    EXPECT_FALSE(take_connections(3.0, 3.0, false));
    EXPECT_FALSE(take_connections(3.0 * kConnectMargin * 0.99, 3.0, false));
    EXPECT_TRUE(take_connections(3.0 * kConnectMargin * 1.01, 3.0, false));
    // A candidate ruled out without them (0) leaves any gain to them.
    EXPECT_TRUE(take_connections(0.5, 0.0, false));
}

}  // namespace
