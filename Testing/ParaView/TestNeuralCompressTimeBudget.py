"""TimeBudget bounds the whole Apply on an unstructured grid: resampling or probing, training and the final
measurement end within 10% of the budget, in a blocking run and in the background (where Apply returns at once
and the panel's status line says what is being prepared). A Stop while the field is still prepared is kept: the job
starts stopped (it was lost: a 10^8-step run trained on and WaitForTraining never returned)."""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

nvtest.load_plugin(globals(), scripted=False)
log, check = nvtest.log, nvtest.check

BUDGET = 10.0
SMALL = dict(BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Seed=1,
             TrainingSteps=1000000, TimeBudget=BUDGET, PSNRInterval=50)

# An unstructured grid of about 500k tetrahedra: resampling and probing it take a noticeable part of the budget.
wavelet = Wavelet(WholeExtent=[-24, 24] * 3)
grid = Tetrahedralize(Input=wavelet)
grid.UpdatePipeline()
cells = grid.GetDataInformation().GetNumberOfCells()
log("input: unstructured grid of %d cells" % cells)
check(cells > 400000, "the input is a large unstructured grid (%d cells)" % cells)


def figures(nc):
    out = servermanager.Fetch(nc)
    return (out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0),
            nvtest.field_value(out, "NeuralSteps"), nvtest.field_value(out, "NeuralTrainingSeconds"),
            nvtest.field_value(out, "NeuralPSNR"))


def within_budget(label, seconds):
    log("%s: the Apply took %.2f s for a %.1f s budget" % (label, seconds, BUDGET))
    check(0.9 * BUDGET <= seconds <= 1.1 * BUDGET,
          "%s: %.2f s within 10%% of the %.1f s budget" % (label, seconds, BUDGET))


for sampling in ("Resample", "Probe"):
    # Blocking: UpdatePipeline returns when the network is measured.
    nc = NeuralCompress(Input=grid, SelectInputScalars=["POINTS", "RTData"], TrainInBackground=0,
                        Sampling=sampling, **SMALL)
    start = time.time()
    nc.UpdatePipeline()
    took = time.time() - start
    state, steps, seconds, psnr = figures(nc)
    log("%s, blocking: %s, %d steps, %.2f s of training, PSNR %.2f dB" % (sampling, state, steps, seconds, psnr))
    within_budget("%s, blocking" % sampling, took)
    check(state == "Finished" and steps > 0 and psnr > 15.0, "%s, blocking: a trained network" % sampling)
    Delete(nc)

    # Background (the GUI's default): Apply returns at once; the budget bounds it up to the measured network.
    nc = NeuralCompress(Input=grid, SelectInputScalars=["POINTS", "RTData"], Sampling=sampling, **SMALL)
    start = time.time()
    nc.UpdatePipeline()
    returned = time.time() - start
    nc.UpdatePropertyInformation()
    status = nc.GetPropertyValue("TrainingStatus")
    log("%s, background: Apply returned after %.3f s, status %r" % (sampling, returned, status))
    check(returned < 0.5, "%s, background: Apply returns at once (%.3f s)" % (sampling, returned))
    check(status.startswith("Preparing:"), "%s, background: the status line says what is prepared (%r)"
          % (sampling, status))
    if sampling == "Resample":
        # Shown while it prepares: nothing to draw yet, and no error ("no network") for the user.
        view = nvtest.render_view([120, 120])
        with nvtest.captured_messages() as messages:
            shown = Show(nc, view)
            Render(view)
        log("shown while preparing: %r" % messages[0][:300])
        check(shown.Representation == "Neural Volume" and "ERR" not in messages[0] and "rror" not in messages[0],
              "Neural Volume of a filter that prepares: no error (%r)" % messages[0][:200])
        # Its geometry is the input's box already (ParaView resets the camera to it on the first Apply).
        preparing_bounds = servermanager.Fetch(nc).GetBounds()
        grid_bounds = grid.GetDataInformation().GetBounds()
        check(all(abs(p - g) < 1e-6 * (1 + abs(g)) for p, g in zip(preparing_bounds, grid_bounds)),
              "the preparing output spans the input's bounds (%r, %r)" % (preparing_bounds, grid_bounds))
    nc.WaitForTraining()
    nc.UpdatePipeline()
    took = time.time() - start
    state, steps, seconds, psnr = figures(nc)
    log("%s, background: %s, %d steps, %.2f s of training, PSNR %.2f dB" % (sampling, state, steps, seconds, psnr))
    within_budget("%s, background" % sampling, took)
    check(state == "Finished" and steps > 0 and psnr > 15.0, "%s, background: a trained network" % sampling)
    Delete(nc)

# Stop before the first step: the Apply returns while the field is still prepared, the user stops at once.
nc = NeuralCompress(Input=grid, SelectInputScalars=["POINTS", "RTData"], Sampling="Resample",
                    SamplingDimensions=[40, 40, 40], **dict(SMALL, TrainingSteps=10 ** 8, TimeBudget=0))
nc.UpdatePipeline()
nc.UpdatePropertyInformation()
status = nc.GetPropertyValue("TrainingStatus")
check(status.startswith("Preparing:"), "stop while preparing: the field is still prepared (%r)" % status)
start = time.time()
nc.StopTraining()
nc.WaitForTraining()
nc.UpdatePipeline()
took = time.time() - start
state, steps, seconds, psnr = figures(nc)
log("stop while preparing: %s after %.2f s, %d steps" % (state, took, steps))
check(state == "Stopped" and steps == 0, "the kept Stop ends the run before its first step (%s, %d steps)"
      % (state, steps))
check(took < 20.0, "the stopped Apply ended in %.2f s (it trained on before)" % took)
Delete(nc)

nvtest.finish()
