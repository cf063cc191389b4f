#pragma once
/// \file nn.hpp
/// Umbrella header for maskadapt's neural-network core (see docs/nn.md).
#include "maskadapt/nn/activation.hpp"
#include "maskadapt/nn/adam.hpp"
#include "maskadapt/nn/gaussian.hpp"
#include "maskadapt/nn/kl.hpp"
#include "maskadapt/nn/mlp.hpp"
#include "maskadapt/nn/normalizer.hpp"
#include "maskadapt/nn/parameter_block.hpp"
#include "maskadapt/nn/popart.hpp"
#include "maskadapt/nn/serialize.hpp"
