// The simulated links between a robot's drivers and its nodes: latency, jitter, loss, order.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autocal/sim/transport.h"

using autocal::sim::DelayLine;
using autocal::sim::DelayQueue;
using autocal::sim::LinkConfig;

namespace {

LinkConfig link(double latency_s, double jitter_s, double drop) {
  LinkConfig c;
  c.latency_s = latency_s;
  c.jitter_s = jitter_s;
  c.drop_probability = drop;
  return c;
}

TEST(Transport, NoDelayReleasesAtOnce) {
  DelayLine line(LinkConfig(), 1);
  EXPECT_FALSE(LinkConfig().active());
  for (double t : {0.0, 0.01, 0.5}) EXPECT_EQ(line.releaseTime(t), t);
}

TEST(Transport, LatencyAndJitterAsConfiguredOrderKept) {
  DelayLine line(link(0.1, 0.02, 0.0), 7);
  std::vector<double> delays;
  double last = -1;
  for (int i = 0; i < 20000; ++i) {
    const double t = i / 30.0;
    const double release = line.releaseTime(t);
    ASSERT_GE(release, last) << "a message overtook the one sent before it";
    ASSERT_GE(release, t);
    last = release;
    delays.push_back(release - t);
  }
  double mean = 0, var = 0;
  for (double d : delays) mean += d / delays.size();
  for (double d : delays) var += (d - mean) * (d - mean) / delays.size();
  EXPECT_NEAR(mean, 0.1, 0.002);
  EXPECT_NEAR(std::sqrt(var), 0.02, 0.002);
}

TEST(Transport, OrderKeptWhenJitterExceedsThePeriod) {
  DelayLine line(link(0.03, 0.05, 0.0), 3);
  double last = -1;
  for (int i = 0; i < 5000; ++i) {
    const double release = line.releaseTime(i / 100.0);
    ASSERT_GE(release, last);
    last = release;
  }
}

TEST(Transport, DropsAtTheConfiguredRateReproduciblyPerSeed) {
  DelayQueue<int> a(link(0.05, 0.0, 0.1), 11), b(link(0.05, 0.0, 0.1), 11);
  int kept = 0;
  for (int i = 0; i < 20000; ++i) {
    const bool ka = a.push(i * 0.01, i), kb = b.push(i * 0.01, i);
    ASSERT_EQ(ka, kb) << "the same seed lost different messages";
    kept += ka;
  }
  EXPECT_NEAR(kept / 20000.0, 0.9, 0.01);
}

TEST(Transport, QueueReleasesInOrderAtTheReleaseTime) {
  DelayQueue<int> q(link(0.1, 0.0, 0.0), 1);
  q.push(0.0, 1);
  q.push(0.05, 2);
  EXPECT_TRUE(q.due(0.099).empty());
  EXPECT_EQ(q.due(0.1), std::vector<int>{1});
  EXPECT_EQ(q.due(0.2), std::vector<int>{2});
  EXPECT_EQ(q.held(), 0u);
}

}  // namespace
