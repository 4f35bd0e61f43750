use lincal_derive::CalibModel;

// A tool frame's keys are those of `base`; its rotation is only seen by `measured_pose`.
#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, alpha = pi/2, home = th1),
    joint(revolute, a = a2, home = th2),
    tool(x = tx, z = 0.1, rol = 0, yaw = tw),
    params(a1 = 0.3, th1 = 0, a2 = 0.2, th2 = 0, tx = 0.05, tw = 0),
    constraint(measured),
)]
struct Robot;

#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, alpha = pi/2, home = th1),
    tool = tx,
    params(a1 = 0.3, th1 = 0, tx = 0.05),
    constraint(measured_pose),
)]
struct Bare;

fn main() {}
