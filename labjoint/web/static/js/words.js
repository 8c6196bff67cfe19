// The server's words, said in the page's terms: messages and reasons written for the CLI
// or the REST API name options (--validate, max_steps, options.friction_coefficient) that
// the page shows under other names, or not at all.

const RULES = [
  [/max_steps \((\d+)\) reached/g, 'the step limit ($1 added effects) was reached'],
  [/max_steps = (\d+) reached/g, 'the step limit ($1 added effects) was reached'],
  [/runs named by --validate/g, 'runs named for validation'],
  [/give options\.friction_coefficient or run a friction test first/g,
    'enter the friction coefficient μ beside the buttons, or record a friction test first'],
  [/identify it from a friction-test run \(`labjoint friction RUN`, or `--friction-run RUN` for one analysis; identify_friction in Python\) or give it \(`--friction MU`\)/g,
    'record a friction test, or enter the friction coefficient μ beside the buttons'],
  [/(\d) um\b/g, '$1 µm'],
];

export function onPage(text) {
  let t = String(text ?? '');
  for (const [re, to] of RULES) t = t.replace(re, to);
  return t;
}
