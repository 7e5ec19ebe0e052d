// Design figures of the per-joint acceleration controller (paper Section 4 plus documented choices).
#pragma once

namespace delta::golden {

// Every figure the paper does not give is a documented choice (hls/README.md, "Joint controller
// fixed-point formats"). The nominal motor figures are datasheet-like values for the Faulhaber
// 1628 024 B and a 66:1 gearhead: assumptions, deliberately a little off the plant's true values.
struct JointControllerParameters {
  double period_s = 1.0e-4;                           // Ts: 10 kHz, as on the paper's dSPACE DS1005
  double reference_cutoff_rad_s = 1200.0;             // g_ref of the pseudo-derivative (paper eq. 6)
  double velocity_gain = 1.0e2;                       // k_v of eq. 5 [1/s]
  double position_gain = 1.0e3;                       // k_p of eq. 5 [1/s^2]
  double velocity_observer_cutoff_rad_s = 2000.0;     // g_v (choice)
  double disturbance_observer_cutoff_rad_s = 2000.0;  // g_d (choice)
  double nominal_inertia_kg_m2 = 1.05e-7;             // m_jjn, rotor side: rotor + arm / g_r^2
  double nominal_torque_constant_nm_per_a = 0.0194;   // K_Tjn
  double gear_ratio = 66.0;                           // g_r: rotor angle = g_r * shaft angle
  double encoder_resolution_deg = 0.01;               // one encoder count, shaft side
  double current_limit_a = 0.5;                       // applied-current limit (drive limit)
  bool disturbance_observer = true;                   // false: i_dis_hat held at 0 (for the rejection test)
};

}  // namespace delta::golden
