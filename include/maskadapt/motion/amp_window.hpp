#pragma once
/// \file amp_window.hpp
/// The discriminator's window: how many consecutive frames one AMP sample holds and how far apart
/// they are. One definition for the motion library (real windows), the imitation task (the
/// agent's windows) and everything that sizes them.
namespace maskadapt {

/// Number of consecutive frames in one AMP discriminator sample (the method's choice).
inline constexpr int kAmpWindowFrames = 5;
/// Spacing of those frames (s): the control rate of the reference humanoid, 30 Hz.
inline constexpr double kAmpFrameDt = 1.0 / 30.0;

}  // namespace maskadapt
