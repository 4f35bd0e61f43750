use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(
    joint(revolute, a = a1, home = th1),
    params(a1 = 0.4, th1 = 0, b1 = -1.8, b2 = 0.5),
)]
struct Robot;

fn main() {}
