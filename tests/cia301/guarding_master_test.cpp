#include "protocol/cia301/guarding_master.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

const GuardingConfig kConfig{100ms, 3, true};  // guard time 100 ms, life time 300 ms

TEST(GuardingMaster, RejectsGuardingSwitchedOff) {
  // Given configurations with guard time 0, factor 0, node 0
  GuardingMaster master;
  // Then each is refused with the reason
  EXPECT_FALSE(master.guard(1, GuardingConfig{0ms, 3}, at(0ms)));
  EXPECT_FALSE(master.guard(1, GuardingConfig{100ms, 0}, at(0ms)));
  EXPECT_FALSE(master.guard(0, kConfig, at(0ms)));
  EXPECT_TRUE(master.guard(1, kConfig, at(0ms)));
}

TEST(GuardingMaster, PollsEveryGuardTime) {
  // Given node 1 guarded from t = 0 with guard time 100 ms
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  // When time reaches 0, 100 ms and 200 ms, with responses in between
  const auto first = master.on_time(at(0ms));
  master.on_frame(encode(GuardResponse{1, false, NmtState::pre_operational}), at(1ms));
  EXPECT_TRUE(master.on_time(at(99ms)).requests.empty());
  const auto second = master.on_time(at(100ms));
  // Then one RTR on 701h (DLC 0) is sent per guard time
  ASSERT_EQ(first.requests.size(), 1u);
  EXPECT_EQ(can::to_candump(first.requests[0]), "701#R");
  EXPECT_EQ(second.requests.size(), 1u);
  EXPECT_TRUE(second.events.empty());
  EXPECT_EQ(master.next_deadline(), at(200ms));
}

TEST(GuardingMaster, FestoToggleSequenceIsAccepted) {
  // Given node 1 right after reset communication, answering 7F, FF, 7F (Festo L1499; digest
  //   vector 13)
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  std::vector<GuardingEvent> events;
  const char* answers[] = {"701#7F", "701#FF", "701#7F"};
  for (int i = 0; i < 3; ++i) {
    master.on_time(at(100ms * i));
    if (auto event = master.on_frame(*can::parse_candump(answers[i]), at(100ms * i + 1ms))) {
      events.push_back(*event);
    }
  }
  // Then only the first response is an event (first state); no toggle error
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, GuardingEventKind::state_changed);
  EXPECT_EQ(events[0].state, NmtState::pre_operational);
  EXPECT_FALSE(master.is_lost(1));
}

TEST(GuardingMaster, SameToggleTwiceIsAToggleError) {
  // Given node 1 that answered 7F (toggle 0)
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  master.on_time(at(0ms));
  master.on_frame(*can::parse_candump("701#7F"), at(1ms));
  master.on_time(at(100ms));
  // When it answers 7F again (toggle not alternated)
  const auto event = master.on_frame(*can::parse_candump("701#7F"), at(101ms));
  // Then it is a toggle error, handled as not received: the request stays unanswered
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, GuardingEventKind::toggle_error);
  EXPECT_EQ(event->toggle, false);
  const auto next = master.on_time(at(200ms));
  ASSERT_EQ(next.events.size(), 1u);
  EXPECT_EQ(next.events[0].kind, GuardingEventKind::no_response);
}

TEST(GuardingMaster, FirstResponseWithToggleOneIsAnError) {
  // Given a strict master (first toggle must be 0)
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  master.on_time(at(0ms));
  // When the first response has toggle 1
  const auto event = master.on_frame(*can::parse_candump("701#FF"), at(1ms));
  // Then it is a toggle error; a lenient master accepts it
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, GuardingEventKind::toggle_error);
  GuardingMaster lenient;
  ASSERT_TRUE(lenient.guard(1, GuardingConfig{100ms, 3, false}, at(0ms)));
  lenient.on_time(at(0ms));
  const auto ok = lenient.on_frame(*can::parse_candump("701#FF"), at(1ms));
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->kind, GuardingEventKind::state_changed);
}

TEST(GuardingMaster, LifeTimeExpiresOnceThenResumes) {
  // Given node 1 answered once at 1 ms (life time 300 ms)
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  master.on_time(at(0ms));
  master.on_frame(*can::parse_candump("701#05"), at(1ms));
  // When it stays silent
  std::vector<GuardingEvent> events;
  for (auto t = 100ms; t <= 600ms; t += 100ms) {
    auto out = master.on_time(at(t));
    if (master.next_deadline() <= at(t)) FAIL() << "deadline not advanced";
    events.insert(events.end(), out.events.begin(), out.events.end());
  }
  // Then: no_response at 200, 300 ms..., life_time_expired once at 301 ms
  int expired = 0;
  for (const auto& event : events) {
    if (event.kind == GuardingEventKind::life_time_expired) {
      ++expired;
      EXPECT_EQ(event.time, at(301ms));
    }
  }
  EXPECT_EQ(expired, 1);
  EXPECT_TRUE(master.is_lost(1));
  // When it answers again with the right toggle (1)
  const auto back = master.on_frame(*can::parse_candump("701#85"), at(601ms));
  // Then guarding is resumed
  ASSERT_TRUE(back);
  EXPECT_EQ(back->kind, GuardingEventKind::resumed);
  EXPECT_FALSE(master.is_lost(1));
}

TEST(GuardingMaster, UnsolicitedAndBootUp) {
  // Given node 1 guarded, no request outstanding yet
  GuardingMaster master;
  ASSERT_TRUE(master.guard(1, kConfig, at(0ms)));
  // When a heartbeat-like frame arrives, then a boot-up
  const auto unsolicited = master.on_frame(*can::parse_candump("701#05"), at(0ms));
  const auto boot = master.on_frame(*can::parse_candump("701#00"), at(0ms));
  // Then they are reported as such
  ASSERT_TRUE(unsolicited && boot);
  EXPECT_EQ(unsolicited->kind, GuardingEventKind::unsolicited_response);
  EXPECT_EQ(boot->kind, GuardingEventKind::boot_up);
}

// A node-1 stand-in on a port: answers each guarding RTR after 1 ms with its state and a toggle
// that alternates (or not, when `broken_toggle`), until `silent_after` requests.
struct GuardedNode {
  can::SimPort& port;
  bool broken_toggle = false;
  int silent_after = 1'000'000;
  int requests = 0;
  bool toggle = false;

  void attach() {
    port.set_frame_handler([this](const can::TimedFrame& frame) {
      if (!frame.frame.is_remote() || frame.frame.id != 0x701) return;
      if (++requests > silent_after) return;
      const bool t = toggle;
      if (!broken_toggle) toggle = !toggle;
      port.start_timer_after(1ms, [this, t] {
        port.send(encode(GuardResponse{1, t, NmtState::operational}));
      });
    });
  }
};

TEST(GuardingMasterPort, ToggleErrorDetectedOnSimulatedBus) {
  // Given a node whose toggle never changes
  can::SimBus bus;
  auto master_port = bus.attach("master");
  auto node_port = bus.attach("node1");
  GuardedNode node{*node_port, true};
  node.attach();
  std::vector<GuardingEvent> events;
  GuardingMasterPort guarding(*master_port, [&](const GuardingEvent& e) { events.push_back(e); });
  master_port->set_frame_handler([&](const can::TimedFrame& frame) { guarding.handle(frame); });
  ASSERT_TRUE(guarding.guard(1, kConfig));
  // When the network runs for 250 ms (requests at 0, 100, 200 ms)
  bus.run_until(at(250ms));
  // Then the first response is accepted and the next two are toggle errors
  ASSERT_EQ(node.requests, 3);
  ASSERT_GE(events.size(), 3u);
  EXPECT_EQ(events[0].kind, GuardingEventKind::state_changed);
  EXPECT_EQ(events[1].kind, GuardingEventKind::toggle_error);
  EXPECT_EQ(events.back().kind, GuardingEventKind::toggle_error);
  EXPECT_FALSE(guarding.last_send_error());
}

TEST(GuardingMasterPort, LifeTimeOnSimulatedBus) {
  // Given a node that answers the first two requests correctly and then falls silent
  can::SimBus bus;
  auto master_port = bus.attach("master");
  auto node_port = bus.attach("node1");
  GuardedNode node{*node_port, false, 2};
  node.attach();
  std::vector<GuardingEvent> events;
  can::TimePoint last_response{};
  bus.add_monitor([&](const can::TimedFrame& frame) {
    if (frame.frame.id == 0x701 && !frame.frame.is_remote()) last_response = frame.timestamp;
  });
  GuardingMasterPort guarding(*master_port, [&](const GuardingEvent& e) { events.push_back(e); });
  master_port->set_frame_handler([&](const can::TimedFrame& frame) { guarding.handle(frame); });
  ASSERT_TRUE(guarding.guard(1, kConfig));
  // When the network runs for 1 s
  bus.run_until(at(1s));
  // Then the life time expires exactly 300 ms after the last valid response
  const GuardingEvent* expired = nullptr;
  for (const auto& event : events) {
    EXPECT_NE(event.kind, GuardingEventKind::toggle_error);
    if (event.kind == GuardingEventKind::life_time_expired) expired = &event;
  }
  ASSERT_NE(expired, nullptr);
  EXPECT_EQ(expired->time, last_response + 300ms);
  EXPECT_TRUE(guarding.master().is_lost(1));
}

}  // namespace
}  // namespace drivecheck::cia301
