// A JVM co-simulation master for flexure's FMUs, on FMI4j (info.laht.fmi4j:fmi-import 0.38.0).
// Run as a single-file program (Java 11+): java -cp "$(cat classpath.txt)" Host.java ARGS
// ARGS: FMU STOP_S STEP_S INPUT_VR INPUT_VALUE OUTPUT_VR[,OUTPUT_VR...]
// Prints "t,y1,y2,..." per communication point, then "state-replay,<max |difference|>" after
// getting the FMU state halfway, stepping on, restoring it and stepping the same steps again.
import java.io.File;
import java.util.Arrays;

import no.ntnu.ihb.fmi4j.importer.fmi2.CoSimulationSlave;
import no.ntnu.ihb.fmi4j.importer.fmi2.Fmu;

public class Host {
    public static void main(String[] args) throws Exception {
        File file = new File(args[0]);
        double stop = Double.parseDouble(args[1]);
        double h = Double.parseDouble(args[2]);
        long[] inputVr = {Long.parseLong(args[3])};
        double[] input = {Double.parseDouble(args[4])};
        long[] outputVr = Arrays.stream(args[5].split(",")).mapToLong(Long::parseLong).toArray();
        int n = (int) Math.round(stop / h);
        try (Fmu fmu = Fmu.from(file)) {
            CoSimulationSlave slave = fmu.asCoSimulationFmu().newInstance("jvm");
            if (!slave.simpleSetup()) throw new IllegalStateException("setup failed");
            slave.writeReal(inputVr, input);
            double[] y = new double[outputVr.length];
            double[][] after = new double[n][];
            long state = 0;
            for (int k = 0; k < n; k++) {
                if (k == n / 2) state = slave.getFMUstate();
                if (!slave.doStep(k * h, h)) throw new IllegalStateException("doStep failed at " + k * h);
                slave.readReal(outputVr, y);
                after[k] = y.clone();
                StringBuilder line = new StringBuilder(Double.toString((k + 1) * h));
                for (double v : y) line.append(',').append(v);
                System.out.println(line);
            }
            byte[] bytes = slave.serializeFMUstate(state);
            slave.freeFMUstate(state);
            long restored = slave.deSerializeFMUstate(bytes);
            slave.setFMUstate(restored);
            double worst = 0.0;
            for (int k = n / 2; k < n; k++) {
                if (!slave.doStep(k * h, h)) throw new IllegalStateException("replay failed at " + k * h);
                slave.readReal(outputVr, y);
                for (int i = 0; i < y.length; i++) worst = Math.max(worst, Math.abs(y[i] - after[k][i]));
            }
            slave.freeFMUstate(restored);
            System.out.println("state-replay," + worst);
            slave.terminate();
            slave.close();
        }
    }
}
