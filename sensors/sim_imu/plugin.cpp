// Plugin entry of sim_imu: the simulator's own field table (stend::sim::SimImuConfig::fields(),
// sim/src/imu.cpp) is the schema, and the factory.
#include <stend/sdk.hpp>

#include <stend/sim/imu.hpp>

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "sim_imu", "0.1.0",
                    "Simulated 3-axis accelerometer + gyroscope + temperature (MPU-6050 defaults)",
                    stend::sim::SimImuConfig::fields(), stend::sim::SimImu)
