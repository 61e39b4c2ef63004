"""Accelerometer and gyroscope multi-position calibration (Gao & Zhang 2019; imu_tk-style gyro; Ferraris)."""
