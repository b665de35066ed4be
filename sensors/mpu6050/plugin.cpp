// Plugin entry of mpu6050_modbus: the driver's field table (Mpu6050ModbusConfig::fields(),
// mpu6050_modbus.cpp) is the schema, and the factory.
#include <stend/sdk.hpp>

#include "mpu6050_modbus.hpp"

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "mpu6050_modbus", "0.1.0",
                    "InvenSense MPU-6050 via the bench microcontroller, MODBUS RTU over a serial port",
                    stend::mpu6050::Mpu6050ModbusConfig::fields(), stend::mpu6050::Mpu6050Modbus)
