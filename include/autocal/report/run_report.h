// The report of one calibration run (doc/calibration_run.md; its files: doc/files.md "The run's
// report"), ROS-free: a RunRecorder is fed what the run published (every stage's status on the one
// status topic, the encoder readings) and says when the run has ended (every stage DONE, or one
// FAILED); the report is then a PNG sheet for a person (the views used and their reprojection
// errors, the image coverage by board corners, the wheel stage's believed path and k per iteration,
// the odometry figures, pass/fail) and summary.yaml with the figures, written atomically beside the
// calibration files. It reads only what the calibration nodes publish and write, never a
// simulator's truth. The parts: run_record.h (the recorder), paths.h, gates.h, sheet.h and
// summary.h; this header gathers them.
#pragma once

#include "autocal/report/gates.h"
#include "autocal/report/paths.h"
#include "autocal/report/run_record.h"
#include "autocal/report/sheet.h"
#include "autocal/report/summary.h"
