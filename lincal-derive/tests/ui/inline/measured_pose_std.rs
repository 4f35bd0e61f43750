use lincal_derive::CalibModel;

// A noise level must be a positive number; the body has two fields only.
#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, alpha = pi/2, home = th1),
    joint(revolute, a = a2, home = th2),
    tool(x = tx, z = 0.1, yaw = 0.1),
    params(a1 = 0.3, th1 = 0, a2 = 0.2, th2 = 0, tx = 0.05),
    constraint(measured_pose(position_std = -2e-5, orientation_std = 0, angle_std = 1e-4)),
)]
struct Robot;

fn main() {}
