// Umbrella header of the entity/component core.
#pragma once

#include "engine/ecs/components.h"
#include "engine/ecs/entity.h"
#include "engine/ecs/schedule.h"
#include "engine/ecs/storage.h"
#include "engine/ecs/world.h"
