"""The shared core every optinav system is built on.

Modules: ``rotations``, ``earth``, ``units``, ``imu_model`` (error and noise models, presets),
``simulate`` (motion and exact IMU outputs), ``strapdown`` (attitude and navigation integration),
``alignment``, ``optimize`` (one ``minimize`` interface), ``observability`` (rank, covariance, CRLB,
Monte Carlo), ``results`` (versioned JSON), ``validate`` and ``progress``.
"""
