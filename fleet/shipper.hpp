#pragma once
// Shipping a station's committed events to the central PostgreSQL: one batch is one INSERT (one
// transaction), idempotent on the event uid (ON CONFLICT DO NOTHING), so a retry, a restart or a
// rebuilt store never duplicates. Where a station stands is read back from the central server
// (its newest event's commit time), so a wiped station PC resumes without re-sending everything.
#include <cstdint>
#include <string>
#include <vector>

#include "daemon/store.hpp"
#include "fleet/pg.hpp"

namespace brakefit::fleet {

struct StationIds {
  std::string station;
  std::string lane;
};

/// Re-sent on resume: events committed this long before the central server's newest one (a
/// station clock that stepped back, two events in one second). Duplicates are dropped centrally.
inline constexpr std::int64_t kResumeMarginS = 3600;

/// The commit time (unix s) to resume from: the station's and lane's newest central event minus
/// the margin; 0 when the server has none.
std::int64_t resume_unix_s(Pg& pg, const StationIds& ids);

struct BatchOutcome {
  std::size_t sent = 0;
  std::size_t inserted = 0;  ///< new central rows (sent - inserted were there already)
  std::int64_t last_row_id = 0;
};

/// Ships these events (oldest first) as one INSERT; with_samples adds the raw samples blob.
/// Creates the months' partitions first (a server function; a station cannot run DDL itself).
BatchOutcome ship_batch(Pg& pg, const StationIds& ids,
                        const std::vector<daemon::StoredEvent>& events,
                        const daemon::EventStore& store, bool with_samples);

/// What the fleet report keys on, taken from an event's results: the hybrid fit (else least
/// squares), D / wheel load and B C D.
struct EventFigures {
  double wheel_load_n = NAN;
  double peak_friction = NAN;
  double slip_stiffness_n = NAN;
  std::string method;
};
EventFigures figures_of(const daemon::StoredEvent& e);

/// The event's uid; a row stored before uids existed gets one derived from its content.
std::string uid_of(const daemon::StoredEvent& e);

}  // namespace brakefit::fleet
