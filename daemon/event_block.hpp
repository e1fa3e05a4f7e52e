#pragma once
// The last-event register block (input registers 100-168), built from an event's stored
// brakefit.event/1 document: the same function publishes a freshly committed event and restores
// the newest stored one after a restart, so the block always describes a row of the store.
#include <cstdint>
#include <string>

#include "daemon/registers.hpp"

namespace brakefit::daemon {

/// event.seq continues across restarts: it is the low 16 bits of the event's row id.
std::uint16_t event_seq(std::int64_t id);

/// seq_begin first, the body, seq last (a reader compares the two to detect a torn read).
/// Throws std::exception when result_json is not a brakefit.event/1 document.
RegisterWrites event_block(const std::string& result_json, std::int64_t id, bool samples_stored);

}  // namespace brakefit::daemon
