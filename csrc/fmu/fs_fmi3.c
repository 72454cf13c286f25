/* FMI 3.0 co-simulation front end of a fullspeed FMU (fs_fmu.h): the
 * standard's functions (fmi3Functions.h, the Modelica Association's header)
 * over fs_fmi_inst. Variables are Float64, Int32 and Boolean scalars; one
 * doStep is one control period; no event mode, no intermediate update, no
 * FMU state. The other interface types and variable types are refused with
 * a logged error. */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../fmi3/fmi3Functions.h"
#include "fs_fmi_inst.h"

typedef struct {
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} front3;

static void log_fmi3(fs_inst *inst, int status, const char *category, const char *message)
{
    const front3 *f = inst->front;
    if (f->log && (status >= FS_ST_ERROR || inst->logging)) f->log(f->env, (fmi3Status)status, category, message);
}

#define INST ((fs_inst *)instance)

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)nCategories;
    (void)categories;
    INST->logging = loggingOn;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    const char *why = NULL;
    if (instantiationToken && strcmp(instantiationToken, FS_FMU_TOKEN) != 0)
        why = "the instantiation token is not this FMU's (its modelDescription.xml belongs to another build)";
    else if (eventModeUsed)
        why = "event mode: this FMU has none (hasEventMode = false)";
    else if (nRequiredIntermediateVariables > 0)
        why = "intermediate variables: this FMU provides none";
    if (why) {
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", why);
        return NULL;
    }
    front3 *f = calloc(1, sizeof(*f));
    if (!f) return NULL;
    f->env = instanceEnvironment;
    f->log = logMessage;
    fs_inst *inst = fs_inst_new(instanceName, log_fmi3, f, loggingOn);
    if (!inst) free(f);
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "model exchange: this FMU is co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "scheduled execution: this FMU is co-simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (!instance) return;
    free(INST->front);
    fs_inst_free(INST);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return (fmi3Status)fs_inst_enter_init(INST, startTime);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) { return (fmi3Status)fs_inst_exit_init(INST); }
fmi3Status fmi3Terminate(fmi3Instance instance) { return (fmi3Status)fs_inst_terminate(INST); }
fmi3Status fmi3Reset(fmi3Instance instance) { return (fmi3Status)fs_inst_reset(INST); }
fmi3Status fmi3EnterEventMode(fmi3Instance instance) { return (fmi3Status)fs_inst_unsupported(INST, "fmi3EnterEventMode"); }
fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return (fmi3Status)fs_inst_unsupported(INST, "fmi3EnterStepMode"); }

/* Get and set of the types this FMU has: each value reference checked, then copied. */
#define GETSET(Name, CType, kind)                                                                              \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],                \
                             size_t nValueReferences, CType values[], size_t nValues)                          \
    {                                                                                                          \
        if (nValues != nValueReferences) return (fmi3Status)fs_inst_unsupported(INST, "arrays (nValues != nValueReferences)"); \
        for (size_t k = 0; k < nValueReferences; ++k) {                                                        \
            if (fs_inst_check(INST, valueReferences[k], kind, 0) != FS_ST_OK) return fmi3Error;               \
            values[k] = (CType)fs_inst_value(INST, valueReferences[k]);                                        \
        }                                                                                                      \
        return fmi3OK;                                                                                         \
    }                                                                                                          \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],                \
                             size_t nValueReferences, const CType values[], size_t nValues)                    \
    {                                                                                                          \
        if (nValues != nValueReferences) return (fmi3Status)fs_inst_unsupported(INST, "arrays (nValues != nValueReferences)"); \
        for (size_t k = 0; k < nValueReferences; ++k) {                                                        \
            if (fs_inst_check(INST, valueReferences[k], kind, 1) != FS_ST_OK) return fmi3Error;               \
            fs_inst_set(INST, valueReferences[k], (double)values[k]);                                          \
        }                                                                                                      \
        return fmi3OK;                                                                                         \
    }

GETSET(Float64, fmi3Float64, FS_FMU_REAL)
GETSET(Int32, fmi3Int32, FS_FMU_INT)
GETSET(Boolean, fmi3Boolean, FS_FMU_BOOL)

/* The types this FMU has none of. */
#define NONE(Name, CType)                                                                                      \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],                \
                             size_t nValueReferences, CType values[], size_t nValues)                          \
    {                                                                                                          \
        (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;                            \
        return (fmi3Status)fs_inst_unsupported(INST, "fmi3Get" #Name);                                         \
    }                                                                                                          \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],                \
                             size_t nValueReferences, const CType values[], size_t nValues)                    \
    {                                                                                                          \
        (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;                            \
        return (fmi3Status)fs_inst_unsupported(INST, "fmi3Set" #Name);                                         \
    }

NONE(Float32, fmi3Float32)
NONE(Int8, fmi3Int8)
NONE(UInt8, fmi3UInt8)
NONE(Int16, fmi3Int16)
NONE(UInt16, fmi3UInt16)
NONE(UInt32, fmi3UInt32)
NONE(Int64, fmi3Int64)
NONE(UInt64, fmi3UInt64)
NONE(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    (void)valueReferences, (void)nValueReferences, (void)values;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    (void)valueReferences, (void)nValueReferences, (void)values;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetClock");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference, (void)nDependencies;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetFMUState");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    (void)FMUState;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetFMUState");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3FreeFMUState");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    (void)FMUState, (void)size;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SerializedFMUStateSize");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    (void)FMUState, (void)serializedState, (void)size;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SerializeFMUState");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    (void)serializedState, (void)size, (void)FMUState;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3DeserializeFMUState");
}

/* The two derivative functions share one signature. */
#define NO_DERIVATIVE(Name)                                                                                    \
    fmi3Status Name(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,              \
                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,  \
                    fmi3Float64 sensitivity[], size_t nSensitivity)                                            \
    {                                                                                                          \
        (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;                 \
        (void)sensitivity, (void)nSensitivity;                                                                 \
        return (fmi3Status)fs_inst_unsupported(INST, #Name);                                                   \
    }

NO_DERIVATIVE(fmi3GetDirectionalDerivative)
NO_DERIVATIVE(fmi3GetAdjointDerivative)

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3EnterConfigurationMode");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3ExitConfigurationMode");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3EvaluateDiscreteStates");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate, (void)terminateSimulation, (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged, (void)nextEventTimeDefined, (void)nextEventTime;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3UpdateDiscreteStates");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3SetTime");
}

/* The model-exchange functions on a state or indicator vector share one signature. */
#define NO_VECTOR(Name, Const)                                                                                 \
    fmi3Status Name(fmi3Instance instance, Const fmi3Float64 values[], size_t n)                               \
    {                                                                                                          \
        (void)values, (void)n;                                                                                 \
        return (fmi3Status)fs_inst_unsupported(INST, #Name);                                                   \
    }

NO_VECTOR(fmi3SetContinuousStates, const)
NO_VECTOR(fmi3GetContinuousStateDerivatives, )
NO_VECTOR(fmi3GetEventIndicators, )
NO_VECTOR(fmi3GetContinuousStates, )
NO_VECTOR(fmi3GetNominalsOfContinuousStates, )

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    *nEventIndicators = 0;
    (void)instance;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    *nContinuousStates = 0;
    (void)instance;
    return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3GetOutputDerivatives");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    const int st = fs_inst_do_step(INST, currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = false;
    *earlyReturn = false;
    /* a stop of the closed loop ends the simulation: the step is done (its outputs are the stop's) */
    *terminateSimulation = st == FS_ST_DISCARD;
    *lastSuccessfulTime = INST->t;
    return st == FS_ST_DISCARD ? fmi3OK : (fmi3Status)st;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference, (void)activationTime;
    return (fmi3Status)fs_inst_unsupported(INST, "fmi3ActivateModelPartition");
}
