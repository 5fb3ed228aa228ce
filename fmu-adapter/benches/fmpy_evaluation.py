"""FMPy on the same trivial FMUs as `cargo bench -p savme-fmu --bench evaluation`: one
evaluation = reset of a reused instance + set-up + initialisation + 100 steps of 0.01 s + reading
the outputs: once as a hand-written loop over FMPy's FMU2Slave / FMU3Slave (the calls savme
makes), once through `fmpy.simulate_fmu` with the instance given. Each FMU given is measured
(FMI 2.0 or 3.0, read from its model description).

    python3 fmu-adapter/benches/fmpy_evaluation.py path/to/testkit.fmu [path/to/testkit3.fmu]
"""
import statistics
import sys
import time

import fmpy
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave


def measure(path):
    md = read_model_description(path)
    unzipdir = extract(path)
    fmi3 = md.fmiVersion.startswith("3.")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    if fmi3:
        fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir,
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    else:
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    fmu.instantiate()

    def evaluation():
        fmu.reset()
        if fmi3:
            fmu.enterInitializationMode(startTime=0.0, stopTime=1.0)
            fmu.setFloat64([vr["x0"], vr["rate"]], [0.0, 0.1])
        else:
            fmu.setupExperiment(startTime=0.0, stopTime=1.0)
            fmu.setReal([vr["x0"], vr["rate"]], [0.0, 0.1])
            fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        t = 0.0
        failed = False
        for _ in range(100):
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
            t += 0.01
            failed = failed or fmu.getBoolean([vr["failed"]])[0]
        steps = fmu.getInt32([vr["steps"]]) if fmi3 else fmu.getInteger([vr["steps"]])
        return failed, steps[0]

    def simulate_fmu():
        # A reused instance must be reset before each simulation (FMPy only terminates it).
        fmu.reset()
        return fmpy.simulate_fmu(unzipdir, model_description=md, fmu_instance=fmu, stop_time=1.0,
                                 step_size=0.01, output_interval=0.01,
                                 start_values={"x0": 0.0, "rate": 0.1}, output=["failed", "steps"])

    for name, f, n in [("hand-written loop (like savme's)", evaluation, 2000),
                       ("fmpy.simulate_fmu", simulate_fmu, 300)]:
        fmu.reset()
        f()
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            f()
            times.append(time.perf_counter() - t0)
        print(f"FMPy {fmpy.__version__}, FMI {md.fmiVersion}, {name}: "
              f"median {statistics.median(times) * 1e6:.1f} µs per evaluation ({n} runs)")


for path in sys.argv[1:]:
    measure(path)
