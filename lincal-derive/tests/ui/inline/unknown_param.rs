use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(
    dim = 2,
    joint(revolute, a = a1, home = th1),
    params(a1 = 0.4, th1 = 0, b1 = -1.8),
    constraint(line(b = [b1, b2])),
)]
struct Robot;

fn main() {}
