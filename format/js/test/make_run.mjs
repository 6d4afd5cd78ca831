#!/usr/bin/env node
// CTest fixture `js_avatar`: trains the tiny avatar run the format/js tests share
// (DIR/run, and DIR/run_skirt: the same with a skirt; they take --run-from DIR). Usage: make_run.mjs --haha PATH --work DIR
import fs from 'node:fs';
import { SKIRT, parseArgs, runner, tinyRun } from './common.mjs';

const opts = parseArgs({});
if (!opts.haha || !opts.work) { console.error('make_run: --haha PATH and --work DIR are required'); process.exit(1); }
fs.rmSync(opts.work, { recursive: true, force: true });
fs.mkdirSync(opts.work, { recursive: true });
const t = Date.now();
console.log(`tiny run: ${tinyRun(runner(opts.haha), opts.work)} (${((Date.now() - t) / 1000).toFixed(1)} s)`);
const t2 = Date.now();
console.log(`tiny run with a skirt: ${tinyRun(runner(opts.haha), opts.work, null, ...SKIRT)} (${((Date.now() - t2) / 1000).toFixed(1)} s)`);
