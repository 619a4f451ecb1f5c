// Runs A. Kaspar's knitskel (xionluhnis/knitskel, MIT) headless, .skel -> DAT, so that
// bench/original.py can time the original system against knitc as a whole process.
// This file is ours: it only require()s knitskel's own modules from a checkout named by
// KNITSKEL_DIR and calls them in the order its browser "save DAT" button does
// (src/ui/output.js `update('save', ...)` and src/ui/output-dat.js `saveDAT`).
//
//   KNITSKEL_DIR=/tmp/knitskel node bench/original-runner.js design.skel out.dat
//
// Shims, each the least that lets the browser path run in node:
//  1. console.log is silenced, as knitskel's own headless harness (tests/test_pipeline.js)
//     does: every stage prints timings and node counts, and we time compiling, not logging.
//  2. The browser reads two form controls; their default values are used instead:
//     #opt_level (we pass 'block', as tests/pipeline.js does; the optimizer only tells
//     'none' apart, so it is the same as the page's default 'group') and #dat_margin
//     (checked by default: the saved DAT gets a 20-pixel margin).
//  3. The page's FileReader/Blob/download become fs.readFileSync / fs.writeFileSync.
// Nothing else is replaced: simplenoise is the real npm package (see bench/README.md).
"use strict";

const fs = require("fs");
const path = require("path");

const DAT_MARGIN = 20; // src/ui/output-dat.js saveDAT with #dat_margin checked
const OPT_LEVEL = "block"; // tests/pipeline.js

function main(argv) {
  const root = process.env.KNITSKEL_DIR;
  if (!root || argv.length !== 2) {
    process.stderr.write("usage: KNITSKEL_DIR=<checkout> node original-runner.js <in.skel> <out.dat>\n");
    return 2;
  }
  const [skelPath, datPath] = argv;
  const src = (name) => require(path.join(path.resolve(root), "src", name));
  console.log = () => {}; // shim 1, before any knitskel code runs

  const assert = src("assert.js");
  const env = src("env.js");
  const Shape = src("shape.js");
  const Schedule = src("schedule.js");
  const Pattern = src("pattern.js");
  const Bed = src("bed.js");
  const Compiler = src("compiler.js");

  // src/ui/skeleton.js loadSkeleton, minus the FileReader (shim 3)
  const data = JSON.parse(fs.readFileSync(skelPath, "utf-8"));
  env.resetGlobal();
  if (Array.isArray(data)) env.loadSkeleton(data);
  else env.load(data);
  env.verbose = false;
  // Pattern.preload() only fetches image resources; none of the seven designs has any.
  if (Object.keys(data.resources || {}).length) {
    process.stderr.write("image resources need a browser; not supported headless\n");
    return 1;
  }

  // src/ui/output.js update('save', ...)
  const start = env.getStartSide();
  if (!start || !start.node) throw new Error("No valid starting node!");
  const shapeGroups = Shape.assemble(start.node, start.path);
  let bed = null;
  for (const shapes of shapeGroups) {
    const schedule = Schedule.create(shapes);
    schedule.trace();
    Pattern.transform(shapes);
    bed = Bed.allocate(schedule, OPT_LEVEL, bed); // shim 2
  }
  bed.simulate();
  const dat = Compiler.generate(bed);

  // src/ui/output-dat.js saveDAT: the Blob it offers for download (shims 2 and 3)
  fs.writeFileSync(datPath, Buffer.from(dat.toBuffer(DAT_MARGIN)));

  // knitskel's assert records failures instead of throwing; a run with any is not a result.
  const errors = assert.errorList();
  if (errors.length) {
    process.stderr.write(`${errors.length} knitskel assertion(s) failed, first: ${errors[0].args.join(" ")}\n`);
    return 1;
  }
  return 0;
}

process.exitCode = main(process.argv.slice(2));
