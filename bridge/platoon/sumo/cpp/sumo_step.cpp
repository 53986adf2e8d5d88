// The SUMO plant's per-vehicle work of a step, in one call for the whole fleet: set every
// vehicle's acceleration, step SUMO, read every lane position and speed back (and what each
// follower's radar sees, and where the background vehicles are). Loaded with ctypes by
// bridge/platoon/sumo/native.py inside the bridge's own Python process, after `import libsumo`, so the
// libsumo it drives is the one the bridge started (linked against the wheel's _libsumo.so,
// which the dynamic loader finds already loaded). It only moves values between libsumo and the
// caller's arrays: every arithmetic operation of the plant stays in Python (numpy), so both
// paths give the same bits.
#include "libsumo_api.h"

#include <time.h>

#include <cstdint>
#include <exception>
#include <string>
#include <vector>

namespace {

// The arrays a step reads and fills (the caller's, one element per vehicle, radar follower or
// background vehicle), given once.
struct Out {
    const double* accel;
    double* lane;
    double* speed;
    uint8_t* ahead;  // 0: nothing ahead, 1: the predecessor, 2: another vehicle
    double* gap;
    double* ahead_speed;
    int64_t* ns;
    uint8_t* on_road;
    double* bg_lane;
};

struct Fleet {
    std::vector<std::string> ids;         // the platoon vehicles, in wire order
    std::vector<int32_t> followers;       // who has a radar (indices into ids)
    double radar_range = -1.0;            // < 0: no radar is read
    std::vector<std::string> background;  // bg0, bg1, ...
    int subscribed = 0;                   // 0: getters; 1, 2: subscriptions (measured only)
    Out o;
    std::string error;
};

int64_t now(clockid_t clock) {
    timespec t;
    clock_gettime(clock, &t);
    return int64_t(t.tv_sec) * 1000000000 + t.tv_nsec;
}

double value(const libsumo::TraCIResults& r, int var) {
    return static_cast<const libsumo::TraCIDouble*>(r.at(var).get())->value;
}

void read_states(Fleet& f) {
    const Out& o = f.o;
    const size_t n = f.ids.size();
    if (f.subscribed == 2) {
        const libsumo::SubscriptionResults all = libsumo::Vehicle::getAllSubscriptionResults();
        for (size_t i = 0; i < n; ++i) {
            const libsumo::TraCIResults& r = all.at(f.ids[i]);
            o.lane[i] = value(r, libsumo::VAR_LANEPOSITION);
            o.speed[i] = value(r, libsumo::VAR_SPEED);
        }
    } else if (f.subscribed == 1) {
        for (size_t i = 0; i < n; ++i) {
            const libsumo::TraCIResults r = libsumo::Vehicle::getSubscriptionResults(f.ids[i]);
            o.lane[i] = value(r, libsumo::VAR_LANEPOSITION);
            o.speed[i] = value(r, libsumo::VAR_SPEED);
        }
    } else {
        for (size_t i = 0; i < n; ++i) {
            o.lane[i] = libsumo::Vehicle::getLanePosition(f.ids[i]);
            o.speed[i] = libsumo::Vehicle::getSpeed(f.ids[i]);
        }
    }
    if (f.radar_range < 0.0) {
        return;
    }
    // SUMO's leader on the lane, whoever it is (getLeader: no leader is an empty id): 1 the
    // platoon's predecessor (the vehicle before the follower in ids), 2 another (a cut-in).
    for (size_t j = 0; j < f.followers.size(); ++j) {
        const int32_t i = f.followers[j];
        const std::pair<std::string, double> ahead =
            libsumo::Vehicle::getLeader(f.ids[i], f.radar_range);
        o.ahead[j] = ahead.first.empty() ? 0 : ahead.first == f.ids[i - 1] ? 1 : 2;
        o.gap[j] = ahead.second;
        o.ahead_speed[j] = ahead.first.empty() ? 0.0 : libsumo::Vehicle::getSpeed(ahead.first);
    }
}

}  // namespace

extern "C" {

// A fleet of n platoon vehicles (SUMO ids), m of them followers with a radar of radar_range
// metres (read when radar_range >= 0), and nb background vehicles; `arrays` are the caller's
// buffers in the order of Out (accel, lane, speed: n; ahead, gap, ahead_speed: m; ns: 2;
// on_road, bg_lane: nb), which must outlive the fleet.
void* platoon_fleet_new(const char* const* ids, int32_t n, const int32_t* followers, int32_t m,
                        double radar_range, const char* const* background, int32_t nb,
                        void* const* arrays) {
    Fleet* f = new Fleet;
    f->ids.assign(ids, ids + n);
    f->followers.assign(followers, followers + m);
    f->radar_range = radar_range;
    f->background.assign(background, background + nb);
    f->o = Out{static_cast<const double*>(arrays[0]), static_cast<double*>(arrays[1]),
               static_cast<double*>(arrays[2]),       static_cast<uint8_t*>(arrays[3]),
               static_cast<double*>(arrays[4]),       static_cast<double*>(arrays[5]),
               static_cast<int64_t*>(arrays[6]),      static_cast<uint8_t*>(arrays[7]),
               static_cast<double*>(arrays[8])};
    return f;
}

void platoon_fleet_free(void* f) { delete static_cast<Fleet*>(f); }

// The message of the last failure.
const char* platoon_fleet_error(void* f) { return static_cast<Fleet*>(f)->error.c_str(); }

// Reads through subscriptions instead of getters (how: 1 per vehicle, 2 all at once); only
// for measuring them (bridge/tools/bench_sumo.py), the plant reads with getters.
int32_t platoon_fleet_subscribe(void* handle, int32_t how) {
    Fleet& f = *static_cast<Fleet*>(handle);
    try {
        const std::vector<int> vars{libsumo::VAR_LANEPOSITION, libsumo::VAR_SPEED};
        for (const std::string& id : f.ids) {
            libsumo::Vehicle::subscribe(id, vars, libsumo::INVALID_DOUBLE_VALUE,
                                        libsumo::INVALID_DOUBLE_VALUE, libsumo::TraCIResults());
        }
        f.subscribed = how;
        return 0;
    } catch (const std::exception& e) {
        f.error = e.what();
        return 1;
    }
}

// Reads every vehicle's lane position and speed (and the radars) as SUMO has them now into
// lane, speed (ahead, gap, ahead_speed). 0, or 2 with the message in platoon_fleet_error.
int32_t platoon_fleet_read(void* handle) {
    Fleet& f = *static_cast<Fleet*>(handle);
    try {
        read_states(f);
        return 0;
    } catch (const std::exception& e) {
        f.error = e.what();
        return 2;
    }
}

// One step: setAcceleration(id, accel[i], duration) for every vehicle in order, SUMO's step,
// then the read above. ns[0], ns[1]: wall and thread CPU time of SUMO's step alone (the clocks
// of Python's perf_counter_ns and thread_time_ns). 0; 1 when setting or stepping failed (SUMO
// did not step, or stepped and raised); 2 when reading failed after the step.
int32_t platoon_fleet_step(void* handle, double duration) {
    Fleet& f = *static_cast<Fleet*>(handle);
    const Out& o = f.o;
    try {
        for (size_t i = 0; i < f.ids.size(); ++i) {
            libsumo::Vehicle::setAcceleration(f.ids[i], o.accel[i], duration);
        }
        const int64_t t0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_THREAD_CPUTIME_ID);
        libsumo::Simulation::step(0.);
        o.ns[0] = now(CLOCK_MONOTONIC) - t0;
        o.ns[1] = now(CLOCK_THREAD_CPUTIME_ID) - c0;
    } catch (const std::exception& e) {
        f.error = e.what();
        return 1;
    }
    return platoon_fleet_read(handle);
}

// The lane positions (bg_lane) of the background vehicles on the road (on_road[b] != 0); one
// SUMO no longer knows (removed some other way, a collision) is marked off the road, as the
// Python path does on libsumo's TraCIException. 0, or 2 with the message.
int32_t platoon_fleet_traffic(void* handle) {
    Fleet& f = *static_cast<Fleet*>(handle);
    uint8_t* on_road = f.o.on_road;
    double* lane = f.o.bg_lane;
    for (size_t b = 0; b < f.background.size(); ++b) {
        if (!on_road[b]) {
            continue;
        }
        try {
            lane[b] = libsumo::Vehicle::getLanePosition(f.background[b]);
        } catch (const libsumo::TraCIException&) {
            on_road[b] = 0;
        } catch (const std::exception& e) {
            f.error = e.what();
            return 2;
        }
    }
    return 0;
}

}  // extern "C"
