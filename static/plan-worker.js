// The Create page's planner, off the page's thread. Planning a large show (100 × 100
// balls for a minute) takes about a second; on the page's own thread it would hold
// every button for that long, the E-STOP too. The page sends
// { module, id, recipe, installation }: `module` the app's js (the page's
// modulepreload link), the recipe and the installation as JSON. The worker loads the
// app once (the planner itself is in the Create chunk, which `plan_recipe` fetches
// on its first call: the page has it cached by then), renders the recipe and plans
// it exactly as the page would, and answers
// { id, report } (the PlanReport as JSON) or { id, error }.
//
// Only the latest request is planned: requests that arrive while a plan runs wait in
// the event loop, so before each plan the worker lets them all arrive and keeps the
// newest (the page ignores answers to older ones anyway).
let app = null;
let latest = null;
let running = false;

function load(module) {
  app ??= import(module).then(async (loaded) => {
    await loaded.default();
    return loaded;
  });
  return app;
}

async function run() {
  running = true;
  try {
    for (;;) {
      // Let every request already queued arrive first.
      await new Promise((resolve) => setTimeout(resolve, 0));
      if (latest === null) {
        break;
      }
      const { module, id, recipe, installation } = latest;
      latest = null;
      try {
        const loaded = await load(module);
        self.postMessage({ id, report: await loaded.plan_recipe(recipe, installation) });
      } catch (err) {
        self.postMessage({ id, error: String(err) });
      }
    }
  } finally {
    running = false;
  }
}

self.onmessage = (event) => {
  latest = event.data;
  if (!running) {
    run();
  }
};
