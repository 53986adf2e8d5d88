// The few functions of libsumo's C++ API that sumo_step.cpp calls, declared as SUMO 1.28.0
// declares them (src/libsumo/Simulation.h, Vehicle.h, TraCIDefs.h). The `libsumo` wheel the
// bridge installs (bridge/requirements.txt) exports them from its _libsumo.so but ships no
// headers; those come only with the `eclipse-sumo` wheel, which is large and not installed for
// runs. Checked against the wheel's symbols with
//     nm -DC bridge/.venv/lib/python3.11/site-packages/libsumo/_libsumo.so | grep 'libsumo::Vehicle::'
// Change them with the libsumo pin: a changed signature no longer links (an undefined symbol
// when the helper is loaded, and the bridge says so).
#pragma once

#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace libsumo {

// What libsumo throws for an unknown vehicle and the like (a std::runtime_error; caught by
// name, as the C++ runtime matches exception types across shared objects).
class TraCIException : public std::runtime_error {
public:
    explicit TraCIException(const std::string& what) : std::runtime_error(what) {}
};

constexpr double INVALID_DOUBLE_VALUE = -1073741824.0;
constexpr int VAR_SPEED = 0x40;
constexpr int VAR_LANEPOSITION = 0x56;

// A subscription's value: a polymorphic base and, for a double, the value after the vtable
// pointer. Only read through pointers libsumo made.
struct TraCIResult {
    virtual ~TraCIResult() {}
};
struct TraCIDouble : TraCIResult {
    double value;
};
typedef std::map<int, std::shared_ptr<TraCIResult>> TraCIResults;
typedef std::map<std::string, TraCIResults> SubscriptionResults;

class Simulation {
public:
    static void step(const double time = 0.);
};

class Vehicle {
public:
    static double getSpeed(const std::string& vehID);
    static double getLanePosition(const std::string& vehID);
    static std::pair<std::string, double> getLeader(const std::string& vehID, double dist = 0.);
    static void setAcceleration(const std::string& vehID, double acceleration, double duration);
    static void subscribe(const std::string& objectID, const std::vector<int>& varIDs,
                          double begin, double end, const TraCIResults& params);
    static const TraCIResults getSubscriptionResults(const std::string& objectID);
    static const SubscriptionResults getAllSubscriptionResults();
};

}  // namespace libsumo
