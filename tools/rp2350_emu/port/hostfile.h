#ifndef ROBORAY_HOSTFILE_H
#define ROBORAY_HOSTFILE_H
#include "py/obj.h"
#endif
