#define MISSING_CONTACTS
#include "sim_base.hpp"
