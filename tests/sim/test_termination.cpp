#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/sim/termination.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;

TEST(Termination, AllowedContactsAndHeadHeight) {
  const Skeleton& s = humanoid_skeleton();
  const FallCriteria c = FallCriteria::for_skeleton(s);
  BodyStates b = forward_kinematics(s, humanoid_standing_pose());
  ContactFlags contacts(22, 0);
  EXPECT_FALSE(has_fallen(c, b, contacts));
  for (int allowed : {hb::LAnkle, hb::RAnkle, hb::LToe, hb::RToe, hb::LWrist, hb::RWrist}) {
    contacts.assign(22, 0);
    contacts[static_cast<std::size_t>(allowed)] = 1;
    EXPECT_FALSE(has_fallen(c, b, contacts)) << s.names[allowed];
  }
  for (int other = 0; other < 22; ++other) {
    if (c.contact_allowed[static_cast<std::size_t>(other)]) continue;
    contacts.assign(22, 0);
    contacts[static_cast<std::size_t>(other)] = 1;
    EXPECT_TRUE(has_fallen(c, b, contacts)) << s.names[other];
  }
  contacts.assign(22, 0);
  b.pos(2, hb::Head) = 0.39;
  EXPECT_TRUE(has_fallen(c, b, contacts));
  b.pos(2, hb::Head) = 0.41;
  EXPECT_FALSE(has_fallen(c, b, contacts));
  EXPECT_THROW(has_fallen(c, b, ContactFlags(3, 0)), Error);
  EXPECT_THROW(FallCriteria::for_skeleton(s, {"L_Foot"}), Error);  // unknown body name
}
