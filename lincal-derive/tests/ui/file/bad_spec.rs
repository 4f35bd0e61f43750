use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(spec = "tests/ui/file/bad_spec.yaml")]
struct Robot;

fn main() {
    // The stub impl keeps this from adding a "trait not implemented" error.
    let _m: &dyn lincal_core::model::CalibModel = &Robot;
}
