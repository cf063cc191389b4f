#include "sim_base.hpp"
