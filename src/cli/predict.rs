//! `lincal predict`: the tip (or tool pose) of every pose for calibrated or nominal
//! parameters, as CSV on stdout.

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::data::{DataLayout, Poses};
use lincal::error::{Error, Location, Result};
use lincal::spec::Spec;

use super::common::{data_layout, io_err, DataArgs};
use super::result_file::ParamsArgs;
use crate::inputs;

/// The arguments of `predict`.
#[derive(clap::Args, Debug)]
pub struct PredictArgs {
    /// The spec (YAML).
    spec: PathBuf,
    #[command(flatten)]
    source: ParamsArgs,
    /// The poses (only the joint columns are used).
    #[arg(required = true, num_args = 1..)]
    data: Vec<PathBuf>,
    #[command(flatten)]
    data_args: DataArgs,
}

/// `predict`: the tips of the spec's chain at each data row's joint readings, as CSV on
/// `out`, with the nominals or a calibration result's values.
pub fn run(out: &mut dyn Write, args: &PredictArgs) -> Result<()> {
    let (data, data_args) = (args.data.as_slice(), &args.data_args);
    let spec_text = inputs::SpecText::read(&args.spec)?;
    let spec = spec_text.spec()?;
    let p = args.source.values(&spec, &spec.estimated_params())?;
    let mut layout = data_layout(DataLayout::of_spec(&spec), data_args, &spec_text)?;
    layout.joints_only = true;
    let paths: Vec<&Path> = data.iter().map(PathBuf::as_path).collect();
    let poses = Poses::from_csv_paths(&paths, &layout)?;
    args.source.warn_beyond_ranges(&spec, &poses);
    write_tips(out, &spec, &poses, &p).map_err(|e| match data {
        [one] => e.in_file(&one.display().to_string()),
        _ => e,
    })
}

use lincal::lincal_core::spec::kinematics::MAX_PREDICTED;

/// Writes the tip at every pose's joint readings and parameters `p` as CSV (`x,y` or
/// `x,y,z`, shortest round-trip decimals).
fn write_tips(out: &mut dyn Write, spec: &Spec, poses: &Poses, p: &[f64]) -> Result<()> {
    let kin = lincal::lincal_core::spec::kinematics::Kinematics::new(spec);
    // A measured pose's spec: the tool frame, `x, y, z` then its quaternion `qw, qx, qy, qz`.
    let pose = spec.is_measured_pose();
    let chain = lincal::lincal_core::spec::chain::Chain::from_spec(spec);
    let dim = if pose { 7 } else { spec.dim };
    // Every tip is computed and checked before the first is written: an error leaves no
    // partial table on stdout.
    let mut tips = vec![0.0; poses.len() * dim];
    for (l, (q, tip)) in poses.q.iter().zip(tips.chunks_exact_mut(dim)).enumerate() {
        if pose {
            let (mut x, mut rot) = ([0.0; 3], [0.0; 9]);
            lincal::model::chain::pose(&chain.factors, q, p, &mut x, &mut rot);
            tip[..3].copy_from_slice(&x);
            tip[3..].copy_from_slice(&lincal::model::rotation::quaternion_from_matrix(&rot));
        } else {
            kin.tip(q, p, tip);
        }
        if let Some(v) = tip
            .iter()
            .find(|v| !v.is_finite() || v.abs() > MAX_PREDICTED)
        {
            return Err(Error::input(
                Location {
                    line: poses.line.get(l),
                    field: Some("--params".to_string()),
                    ..Location::default()
                },
                format!(
                    "the predicted tip of pose {l} has a coordinate {v:e}, beyond \
                     {MAX_PREDICTED:e}: the parameters are not a robot's"
                ),
            ));
        }
    }
    let mut w = std::io::BufWriter::new(out);
    let header = match dim {
        2 => "x,y\n",
        7 => "x,y,z,qw,qx,qy,qz\n",
        _ => "x,y,z\n",
    };
    w.write_all(header.as_bytes()).map_err(|e| io_err(&e))?;
    let mut line = String::new();
    for tip in tips.chunks_exact(dim) {
        line.clear();
        for (i, v) in tip.iter().enumerate() {
            if i > 0 {
                line.push(',');
            }
            line.push_str(&format!("{v:?}"));
        }
        line.push('\n');
        w.write_all(line.as_bytes()).map_err(|e| io_err(&e))?;
    }
    w.flush().map_err(|e| io_err(&e))
}
