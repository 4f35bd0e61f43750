use lincal_derive::CalibModel;

// `measured_pose` is 3-D; a planar arm's tool is `[tx, ty]`, not a frame.
#[derive(CalibModel)]
#[calib(
    dim = 2,
    joint(revolute, a = a1, home = th1),
    joint(revolute, a = a2, home = th2),
    tool(x = tx, yaw = tw),
    params(a1 = 0.3, th1 = 0, a2 = 0.2, th2 = 0, tx = 0.05, tw = 0),
    constraint(measured_pose(position_std = 2e-5, orientation_std = 5e-5)),
)]
struct Robot;

fn main() {}
