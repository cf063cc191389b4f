#define BODY_STATES_BY_VALUE
#include "sim_base.hpp"
